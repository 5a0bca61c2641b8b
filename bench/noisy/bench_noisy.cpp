// The noisy benchmark (docs/noisy.md): gp, vhgp, TuRBO, CMA-ES and random search on the `noisy` task's problems
// (function × noise model × level × d), S seeds each. Judged by regret_recommended: the noise-free cost of
// summary.json's recommended_theta minus f*. Prints per-problem medians [q1, q3], win/tie/loss counts grouped
// into heteroscedastic / homoscedastic / noiseless problems, median study times, and writes every run as CSV.
//
//   build/bin/bench_noisy [--functions a,b|all] [--noises a,b|all] [--levels moderate,severe] [--dims 2,5]
//                         [--seeds N | A-B | a,b,c] [--algorithms gp,vhgp,turbo,cma_es,random]
//                         [--add-algorithm NAME=YAML] [--budget N] [--threads T] [--jobs J]
//                         [--out DIR] [--csv FILE] [--reuse]
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "noise_models.hpp"
#include "noisy_functions.hpp"
#include "varbo/errors.hpp"
#include "varbo/loader.hpp"
#include "varbo/log.hpp"
#include "varbo/study.hpp"

namespace fs = std::filesystem;
using namespace varbo;
using namespace varbo::tasks::noisy;

namespace {

// ---- configuration ----

struct AlgorithmConfig {
  std::string name, yaml;
};

/// The compared algorithms, each with the plain defaults except the one key that makes it what it is.
const std::vector<AlgorithmConfig>& standard_algorithms() {
  static const std::vector<AlgorithmConfig> a = {
      {"gp", "{type: bo}"},
      {"vhgp", "{type: bo, surrogate: {type: vhgp}}"},
      {"turbo", "{type: bo, region: {type: trust_region}}"},
      {"cma_es", "{type: cma_es}"},
      {"random", "{type: random}"},
  };
  return a;
}

/// (a, b): "a beats b" counts; printed when both are run.
const std::vector<std::pair<std::string, std::string>> kPairs = {
    {"vhgp", "gp"}, {"gp", "random"}, {"gp", "cma_es"}, {"vhgp", "random"}, {"vhgp", "cma_es"}, {"turbo", "gp"}};

/// B(d): 50 for d ≤ 3, 100 for d ≤ 6, 150 beyond (≈ 50·√(d/2), rounded to a round number).
long default_budget(Index d) { return d <= 3 ? 50 : d <= 6 ? 100 : 150; }

struct Problem {
  std::string function, noise, level;  // level "-" for noise none
  Index dim = 2;
  std::string id() const {
    return noise == "none" ? fmt::format("{}-d{}-none", function, dim) : fmt::format("{}-d{}-{}-{}", function, dim, noise, level);
  }
  std::string task_yaml(long instance) const {
    return fmt::format("{{type: noisy, function: {}, dim: {}, instance: {}, noise: {}{}}}", function, dim, instance,
                       noise, noise == "none" ? "" : ", level: " + level);
  }
  std::string group() const {
    if (noise == "none") return "noiseless";
    return heteroscedastic(noise_model_from_name(noise)) ? "heteroscedastic" : "homoscedastic";
  }
};

struct Job {
  Problem problem;
  long seed = 1;  ///< also the instance
  AlgorithmConfig algorithm;
  long budget = 0;
  int threads = 0;
  std::string folder;
  std::string study_yaml() const {
    return fmt::format("task: {}\nbudget: {}\nseed: {}\nalgorithm: {}\n", problem.task_yaml(seed), budget, seed,
                       algorithm.yaml);
  }
};

struct Result {
  double regret_recommended = NAN;          ///< computed here from recommended_theta
  double regret_recommended_summary = NAN;  ///< summary.json's own, once the framework writes it
  double regret_best_observed = NAN;        ///< summary.json's simple_regret (oracle: best noise-free value seen)
  double best_cost = NAN, seconds = NAN;
  long evaluations = 0, failed = 0;
  std::string recommended_source, recommendation_rule, theta, error;
};

// ---- small helpers ----

std::vector<std::string> split(const std::string& s, char sep = ',') {
  std::vector<std::string> out;
  std::stringstream in(s);
  std::string item;
  while (std::getline(in, item, sep))
    if (!item.empty()) out.push_back(item);
  return out;
}

[[noreturn]] void usage_error(const std::string& message) {
  std::fprintf(stderr,
               "bench_noisy: %s\nusage: bench_noisy [--functions a,b|all] [--noises a,b|all] [--levels moderate,severe] "
               "[--dims 2,5] [--seeds N|A-B|a,b] [--algorithms gp,vhgp,turbo,cma_es,random] [--add-algorithm NAME=YAML] "
               "[--budget N] [--threads T] [--jobs J] [--out DIR] [--csv FILE] [--reuse]\n",
               message.c_str());
  std::exit(2);
}

long to_long(const std::string& flag, const std::string& s, long lo) {
  try {
    std::size_t pos = 0;
    const long v = std::stol(s, &pos);
    if (pos == s.size() && v >= lo) return v;
  } catch (const std::exception&) {
  }
  usage_error(fmt::format("{} expects an integer >= {}, got '{}'", flag, lo, s));
}

std::vector<long> parse_seeds(const std::string& s) {
  std::vector<long> seeds;
  if (s.find(',') != std::string::npos) {
    for (const auto& x : split(s)) seeds.push_back(to_long("--seeds", x, 1));
  } else if (const auto dash = s.find('-'); dash != std::string::npos) {
    const long a = to_long("--seeds", s.substr(0, dash), 1), b = to_long("--seeds", s.substr(dash + 1), a);
    for (long k = a; k <= b; ++k) seeds.push_back(k);
  } else {
    for (long k = 1; k <= to_long("--seeds", s, 1); ++k) seeds.push_back(k);
  }
  return seeds;
}

std::vector<std::string> pick(const std::string& flag, const std::string& arg, const std::vector<std::string>& known) {
  if (arg == "all") return known;
  auto v = split(arg);
  for (const auto& x : v)
    if (std::find(known.begin(), known.end(), x) == known.end()) {
      std::string k;
      for (const auto& n : known) k += (k.empty() ? "" : ", ") + n;
      usage_error(fmt::format("{}: unknown '{}'; known: {}", flag, x, k));
    }
  return v;
}

double quantile(std::vector<double> v, double q) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return std::isnan(x); }), v.end());
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const std::size_t lo = static_cast<std::size_t>(pos), hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

/// Tie: |a - b| ≤ max(1e-9, 1e-3·max(|a|, |b|)) (absolute 1e-9 or relative 1e-3, whichever is larger).
int compare(double a, double b) {
  if (std::isnan(a) || std::isnan(b)) return 2;  // not comparable (a failed run)
  if (std::abs(a - b) <= std::max(1e-9, 1e-3 * std::max(std::abs(a), std::abs(b)))) return 0;
  return a < b ? 1 : -1;
}

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// ---- running one study and scoring it ----

void run_job(const Job& job, const Registry& reg) {
  fs::create_directories(job.folder);
  {
    std::ofstream(job.folder + "/bench_job.yaml") << job.study_yaml();
  }
  RunOverrides ov;
  ov.progress = false;
  ov.output = job.folder;
  ov.threads = job.threads;
  try {
    const StudyConfig s = parse_study(ConfigNode::parse(job.study_yaml(), job.folder + "/bench_job.yaml"), reg);
    run_study(s, reg, ov);
    fs::remove(job.folder + "/error.txt");
  } catch (const std::exception& e) {
    std::ofstream(job.folder + "/error.txt") << e.what() << "\n";
  }
}

bool reusable(const Job& job) {
  if (read_text(job.folder + "/bench_job.yaml") != job.study_yaml()) return false;
  if (fs::exists(job.folder + "/error.txt")) return false;
  try {
    const auto j = nlohmann::json::parse(read_text(job.folder + "/summary.json"));
    return j.value("evaluations", 0L) >= job.budget;
  } catch (const std::exception&) {
    return false;
  }
}

/// Reads the run folder; regret_recommended = task.noiseless_cost(recommended_theta) - f*, with the task built
/// exactly as the study built it (same YAML, same registry).
Result score(const Job& job, const Registry& reg) {
  Result r;
  if (fs::exists(job.folder + "/error.txt")) {
    r.error = read_text(job.folder + "/error.txt");
    r.error.erase(std::remove(r.error.begin(), r.error.end(), '\n'), r.error.end());
    return r;
  }
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(read_text(job.folder + "/summary.json"));
  } catch (const std::exception& e) {
    r.error = std::string("no readable summary.json: ") + e.what();
    return r;
  }
  r.evaluations = j.value("evaluations", 0L);
  r.failed = j.value("failed", 0L);
  r.seconds = j.value("seconds", NAN);
  r.best_cost = j.value("best_cost", NAN);
  // regret_best_observed since the summary rework; simple_regret before it (same oracle figure).
  r.regret_best_observed = j.value("regret_best_observed", j.value("simple_regret", NAN));
  r.recommendation_rule = j.value("recommendation_rule", std::string());
  if (j.contains("regret_recommended")) r.regret_recommended_summary = j["regret_recommended"].get<double>();
  const char* key = j.contains("recommended_theta") ? "recommended_theta" : "best_theta";
  r.recommended_source = j.contains(key) ? (key == std::string("best_theta") ? "best_observed" : "recommended") : "none";
  if (!j.contains(key)) {
    r.error = "summary.json has neither recommended_theta nor best_theta";
    return r;
  }
  const auto t = j[key].get<std::vector<double>>();
  Vec theta = Eigen::Map<const Vec>(t.data(), static_cast<Index>(t.size()));
  for (std::size_t i = 0; i < t.size(); ++i) r.theta += fmt::format("{}{:.17g}", i ? ";" : "", t[i]);
  const auto task = reg.create<Task>(job.problem.task_yaml(job.seed), BuildContext{});
  const auto opt = task->optimum();
  const auto f = task->noiseless_cost(theta);
  if (!opt || !f) {
    r.error = "the task does not know its noise-free cost";
    return r;
  }
  r.regret_recommended = *f - opt->cost;
  if (!std::isnan(r.regret_recommended_summary) &&
      std::abs(r.regret_recommended_summary - r.regret_recommended) > 1e-9 * std::max(1.0, std::abs(r.regret_recommended)))
    std::fprintf(stderr, "warning: %s: summary.json regret_recommended %.17g != %.17g computed here\n",
                 job.folder.c_str(), r.regret_recommended_summary, r.regret_recommended);
  return r;
}

std::string fmt_g(double x) { return std::isnan(x) ? "nan" : fmt::format("{:.2g}", x); }

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> functions = {"sphere", "rosenbrock", "ellipsoid", "rastrigin", "gallagher", "branin"};
  std::vector<std::string> noises = {"additive", "multiplicative", "cauchy", "input_dependent"};
  std::vector<std::string> levels = {"moderate", "severe"};
  std::vector<Index> dims = {2};
  std::vector<long> seeds = parse_seeds("5");
  std::vector<std::string> algorithm_names = {"gp", "vhgp", "turbo", "cma_es", "random"};
  std::vector<AlgorithmConfig> algorithms_known = standard_algorithms();
  std::optional<long> budget;
  int threads = 1, jobs = 1;
  bool reuse = false;
  std::string out = (fs::temp_directory_path() / "varbo_bench_noisy").string(), csv;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) usage_error(a + " needs a value");
      return argv[++i];
    };
    if (a == "--functions") functions = pick(a, value(), noisy_function_names());
    else if (a == "--noises") noises = pick(a, value(), noise_model_names());
    else if (a == "--levels") levels = pick(a, value(), {"moderate", "severe"});
    else if (a == "--dims") {
      dims.clear();
      for (const auto& d : split(value())) dims.push_back(to_long("--dims", d, 1));
    } else if (a == "--seeds") seeds = parse_seeds(value());
    else if (a == "--algorithms") algorithm_names = split(value());
    else if (a == "--add-algorithm") {
      const std::string v = value();
      const auto eq = v.find('=');
      if (eq == std::string::npos || eq == 0) usage_error("--add-algorithm expects NAME=YAML");
      algorithms_known.push_back({v.substr(0, eq), v.substr(eq + 1)});
      algorithm_names.push_back(v.substr(0, eq));
    } else if (a == "--budget") budget = to_long(a, value(), 1);
    else if (a == "--threads") threads = static_cast<int>(to_long(a, value(), 0));
    else if (a == "--jobs") jobs = static_cast<int>(to_long(a, value(), 1));
    else if (a == "--out") out = value();
    else if (a == "--csv") csv = value();
    else if (a == "--reuse") reuse = true;
    else usage_error("unknown argument '" + a + "'");
  }
  if (csv.empty()) csv = out + "/results.csv";
  std::vector<AlgorithmConfig> algorithms;
  for (const auto& n : algorithm_names) {
    auto it = std::find_if(algorithms_known.begin(), algorithms_known.end(), [&](const AlgorithmConfig& x) { return x.name == n; });
    if (it == algorithms_known.end()) usage_error("--algorithms: unknown '" + n + "' (gp, vhgp, turbo, cma_es, random, or --add-algorithm)");
    if (std::none_of(algorithms.begin(), algorithms.end(), [&](const AlgorithmConfig& x) { return x.name == n; })) algorithms.push_back(*it);
  }

  // Problems: function × noise × level × d; fixed-dimension functions (branin d = 2, hartmann6 d = 6) once, at
  // their own dimension, whatever --dims; noise `none` once (no level).
  std::vector<Problem> problems;
  for (const auto& fn : functions) {
    const auto& spec = noisy_function_spec(fn);
    std::vector<Index> ds;
    if (spec.fixed_dim > 0) ds = {spec.fixed_dim};
    else
      for (Index d : dims)
        if (d >= spec.min_dim) ds.push_back(d);
    for (Index d : ds)
      for (const auto& nz : noises)
        for (const auto& lv : nz == "none" ? std::vector<std::string>{"-"} : levels) problems.push_back({fn, nz, lv, d});
  }
  if (problems.empty()) usage_error("no problem selected");

  set_log_level(LogLevel::Error);
  Registry& reg = default_registry();
  if (!reg.try_find(Kind::Task, "noisy")) {
    std::fprintf(stderr, "bench_noisy: the 'noisy' task plugin (libvarbo_tasks_noisy.so) is not loaded\n");
    return 1;
  }
  // Validate every configuration once, before any study runs (a typo in --add-algorithm fails here, not later).
  for (const auto& alg : algorithms)
    try {
      parse_study(ConfigNode::parse(fmt::format("task: {}\nbudget: 10\nalgorithm: {}\n", problems[0].task_yaml(1), alg.yaml),
                                    "<" + alg.name + ">"),
                  reg);
    } catch (const ConfigError& e) {
      std::fprintf(stderr, "bench_noisy: algorithm %s: %s\n", alg.name.c_str(), e.what());
      return 2;
    }

  // Jobs, seed-major so that a partial run (or a slow one) covers every problem early.
  std::vector<Job> all;
  for (long s : seeds)
    for (const auto& p : problems)
      for (const auto& alg : algorithms) {
        Job j;
        j.problem = p;
        j.seed = s;
        j.algorithm = alg;
        j.budget = budget ? *budget : default_budget(p.dim);
        j.threads = threads;
        j.folder = fmt::format("{}/{}/{}/s{}", out, p.id(), alg.name, s);
        all.push_back(j);
      }

  // Header: everything needed to reproduce the table.
  std::printf("bench_noisy: %zu problems x %zu seeds x %zu algorithms = %zu studies; threads per study %d, %d process(es)\n",
              problems.size(), seeds.size(), algorithms.size(), all.size(), threads, jobs);
  std::string seed_list;
  for (long s : seeds) seed_list += (seed_list.empty() ? "" : ",") + std::to_string(s);
  std::printf("seeds: %s (seed s runs instance s of every function)\n", seed_list.c_str());
  if (budget) std::printf("budget: %ld evaluations\n", *budget);
  else std::printf("budget B(d): 50 for d <= 3, 100 for 4 <= d <= 6, 150 for d >= 7\n");
  for (const auto& alg : algorithms) std::printf("  %-8s %s\n", alg.name.c_str(), alg.yaml.c_str());
  std::printf("task: {type: noisy, function: F, dim: d, instance: s, noise: N, level: L}  (docs/noisy.md)\n");
  std::printf("regret_recommended = f(recommended_theta from summary.json) - f*, f noise-free (Task::noiseless_cost)\n\n");
  std::fflush(stdout);

  // Run: in this process, or in J forked workers taking every J-th job (results go to the run folders).
  std::vector<std::size_t> pending_jobs;
  for (std::size_t k = 0; k < all.size(); ++k)
    if (!(reuse && reusable(all[k]))) pending_jobs.push_back(k);
  auto work = [&](int worker) {
    for (std::size_t t = static_cast<std::size_t>(worker); t < pending_jobs.size(); t += static_cast<std::size_t>(jobs)) {
      const Job& j = all[pending_jobs[t]];
      run_job(j, reg);
      const Result r = score(j, reg);
      std::fprintf(stderr, "[%zu/%zu] %s %s s%ld: regret_recommended %s (%.1f s)%s%s\n", t + 1, pending_jobs.size(),
                   j.problem.id().c_str(), j.algorithm.name.c_str(), j.seed, fmt_g(r.regret_recommended).c_str(),
                   r.seconds, r.error.empty() ? "" : " error: ", r.error.c_str());
    }
  };
  if (jobs <= 1) {
    work(0);
  } else {
    std::fflush(nullptr);
    std::vector<pid_t> children;
    for (int w = 0; w < jobs; ++w) {
      const pid_t pid = fork();
      if (pid < 0) {
        std::perror("fork");
        return 1;
      }
      if (pid == 0) {
        work(w);
        std::fflush(nullptr);
        _exit(0);
      }
      children.push_back(pid);
    }
    for (pid_t pid : children) {
      int status = 0;
      waitpid(pid, &status, 0);
      if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
        std::fprintf(stderr, "warning: worker %d ended abnormally; its remaining runs show as errors\n", static_cast<int>(pid));
    }
  }

  // Collect.
  std::vector<Result> results(all.size());
  for (std::size_t k = 0; k < all.size(); ++k) results[k] = score(all[k], reg);
  {
    fs::create_directories(fs::path(csv).parent_path().empty() ? "." : fs::path(csv).parent_path());
    std::ofstream f(csv);
    f << "problem,function,dim,noise,level,group,instance,seed,algorithm,budget,evaluations,failed,recommended_source,"
         "recommendation_rule,regret_recommended,regret_recommended_summary,regret_best_observed,best_cost,seconds,"
         "recommended_theta,error\n";
    for (std::size_t k = 0; k < all.size(); ++k) {
      const Job& j = all[k];
      const Result& r = results[k];
      std::string err = r.error;
      std::replace(err.begin(), err.end(), '"', '\'');
      f << fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{},{:.17g},{:.17g},{:.17g},{:.17g},{:.3f},{},\"{}\"\n",
                       j.problem.id(), j.problem.function, j.problem.dim, j.problem.noise, j.problem.level,
                       j.problem.group(), j.seed, j.seed, j.algorithm.name, j.budget, r.evaluations, r.failed,
                       r.recommended_source, r.recommendation_rule, r.regret_recommended, r.regret_recommended_summary,
                       r.regret_best_observed, r.best_cost, r.seconds, r.theta, err);
    }
  }

  // regret[problem][algorithm][seed]
  std::map<std::string, std::map<std::string, std::map<long, double>>> regret;
  std::map<std::string, std::map<Index, std::vector<double>>> seconds;
  int errors = 0;
  for (std::size_t k = 0; k < all.size(); ++k) {
    regret[all[k].problem.id()][all[k].algorithm.name][all[k].seed] = results[k].regret_recommended;
    seconds[all[k].algorithm.name][all[k].problem.dim].push_back(results[k].seconds);
    errors += !results[k].error.empty();
  }

  std::printf("regret_recommended: median [q1, q3] over %zu seeds\n\n| problem |", seeds.size());
  for (const auto& a : algorithms) std::printf(" %s |", a.name.c_str());
  std::printf("\n|---|");
  for (std::size_t i = 0; i < algorithms.size(); ++i) std::printf("---|");
  std::printf("\n");
  for (const auto& p : problems) {
    std::printf("| %s |", p.id().c_str());
    for (const auto& a : algorithms) {
      std::vector<double> v;
      for (const auto& [s, x] : regret[p.id()][a.name]) v.push_back(x);
      std::printf(" %s [%s, %s] |", fmt_g(quantile(v, 0.5)).c_str(), fmt_g(quantile(v, 0.25)).c_str(),
                  fmt_g(quantile(v, 0.75)).c_str());
    }
    std::printf("\n");
  }

  const std::vector<std::string> groups = {"heteroscedastic", "homoscedastic", "noiseless", "all"};
  std::printf("\nwin/tie/loss of A vs B on regret_recommended over (problem, seed) pairs; tie: |a - b| <= max(1e-9, "
              "1e-3 max(|a|, |b|)); heteroscedastic = multiplicative, uniform_multiplicative, cauchy, input_dependent\n\n");
  std::printf("| A vs B |");
  for (const auto& g : groups) std::printf(" %s W/T/L (win %%) |", g.c_str());
  std::printf("\n|---|---|---|---|---|\n");
  std::set<std::string> have;
  for (const auto& a : algorithms) have.insert(a.name);
  for (const auto& [a, b] : kPairs) {
    if (!have.count(a) || !have.count(b)) continue;
    std::printf("| %s vs %s |", a.c_str(), b.c_str());
    for (const auto& g : groups) {
      int w = 0, t = 0, l = 0;
      for (const auto& p : problems) {
        if (g != "all" && p.group() != g) continue;
        for (long s : seeds) {
          const int c = compare(regret[p.id()][a][s], regret[p.id()][b][s]);
          w += c == 1;
          t += c == 0;
          l += c == -1;
        }
      }
      const int n = w + t + l;
      if (n == 0) std::printf(" - |");
      else std::printf(" %d/%d/%d (%.0f %%) |", w, t, l, 100.0 * w / n);
    }
    std::printf("\n");
  }

  std::printf("\nmedian seconds per study\n\n| algorithm |");
  std::set<Index> ds;
  for (const auto& p : problems) ds.insert(p.dim);
  for (Index d : ds) std::printf(" d = %ld |", static_cast<long>(d));
  std::printf("\n|---|");
  for (std::size_t i = 0; i < ds.size(); ++i) std::printf("---|");
  std::printf("\n");
  for (const auto& a : algorithms) {
    std::printf("| %s |", a.name.c_str());
    for (Index d : ds) std::printf(" %.1f |", quantile(seconds[a.name][d], 0.5));
    std::printf("\n");
  }
  std::printf("\nCSV: %s%s\n", csv.c_str(), errors ? fmt::format("  ({} run(s) failed: see its error column)", errors).c_str() : "");
  return errors ? 1 : 0;
}
