// Does warping the costs help GP-BO? Plain `bo` defaults with `gp` (output_transform: none vs yeo_johnson) on
// badly scaled problems (Rosenbrock on its usual box, costs exp(Branin/20)) and well-scaled ones (Branin,
// Hartmann-6, and Branin and Hartmann-3 with additive noise); regret of the *recommended* θ (summary's recommended_theta, scored noise-free) and of the best
// observed θ, median [q1, q3] over seeds, and per-seed wins of yeo_johnson (ratio < 0.9) / ties / losses (> 1.1).
//
//   nice -n 10 build/bin/bench_output_transform [--seeds 8] [--threads 1] [--surrogate gp|vhgp] [--only NAME-PREFIX] [--first-seed K]
//
// Prints a Markdown table (docs/output_transform.md).
#include <unistd.h>

#include <fmt/format.h>

#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "bo_table_config.hpp"
#include "varbo/csv.hpp"
#include "varbo/loader.hpp"
#include "varbo/log.hpp"
#include "varbo/study.hpp"
#include "varbo/task.hpp"

using namespace varbo;
using varbo::bench::quantile;

namespace {

double branin(double x1, double x2) {
  const double pi = M_PI;
  const double t = x2 - 5.1 / (4 * pi * pi) * x1 * x1 + 5 / pi * x1 - 6;
  return t * t + 10 * (1 - 1 / (8 * pi)) * std::cos(x1) + 10;
}

struct Problem {
  std::string name, task;
  int budget;
  /// Noise-free cost of θ when the task cannot say (the external exp-Branin); else the task's noiseless_cost.
  std::function<double(const Vec&)> cost;
  double optimum = std::numeric_limits<double>::quiet_NaN();  ///< f*, when not the task's
};

struct Outcome {
  double recommended = NAN, best = NAN, seconds = 0;
};

Outcome run(const Problem& p, const std::string& surrogate, const std::string& transform, int seed, int threads,
            const Registry& reg, const std::string& out) {
  const std::string yaml = fmt::format(
      "task: {}\nbudget: {}\nseed: {}\nalgorithm: {{type: bo, surrogate: {{type: {}, output_transform: {}}}}}\n",
      p.task, p.budget, seed, surrogate, transform);
  StudyConfig s = parse_study(ConfigNode::parse(yaml, "<bench>"), reg);
  RunOverrides ov;
  ov.progress = false;
  ov.output = out;
  ov.threads = threads;
  ov.overwrite = true;  // a benchmark rewrites its scratch folders
  const RunSummary sum = run_study(s, reg, ov);
  BuildContext tctx;
  tctx.seed = s.seed;
  const std::unique_ptr<Task> task = reg.create<Task>(s.task, tctx);
  const double fstar = std::isnan(p.optimum) ? task->optimum()->cost : p.optimum;
  auto cost_of = [&](const Vec& theta) { return p.cost ? p.cost(theta) : *task->noiseless_cost(theta); };
  Outcome o;
  o.seconds = sum.seconds;
  if (sum.recommended_theta) o.recommended = cost_of(*sum.recommended_theta) - fstar;
  // Best observed: the lowest noise-free cost among the evaluated θ (trials.csv, one column per parameter).
  const auto rows = read_csv_cells(out + "/trials.csv");
  const std::vector<std::string> names = task->domain().names;
  std::vector<std::size_t> cols;
  for (std::size_t j = 0; j < names.size(); ++j) {
    const std::string name = names[j].empty() ? fmt::format("x{}", j + 1) : names[j];
    std::size_t c = 0;
    while (c < rows[0].size() && rows[0][c] != name) ++c;
    cols.push_back(c);
  }
  if (names.empty())
    for (std::size_t c = 0; c < rows[0].size(); ++c)
      if (rows[0][c].size() > 1 && rows[0][c][0] == 'x' && std::isdigit(static_cast<unsigned char>(rows[0][c][1]))) cols.push_back(c);
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t r = 1; r < rows.size(); ++r) {
    Vec theta(static_cast<Index>(cols.size()));
    for (std::size_t j = 0; j < cols.size(); ++j) theta(static_cast<Index>(j)) = std::stod(rows[r][cols[j]]);
    best = std::min(best, cost_of(theta));
  }
  o.best = best - fstar;
  return o;
}

std::string summary(const std::vector<double>& v) {
  return fmt::format("{:.2g} [{:.2g}, {:.2g}]", quantile(v, 0.5), quantile(v, 0.25), quantile(v, 0.75));
}

}  // namespace

int main(int argc, char** argv) {
  int seeds = 8, threads = 1, first_seed = 1;
  std::string surrogate = "gp", only;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--seeds" && i + 1 < argc) seeds = std::atoi(argv[++i]);
    else if (a == "--threads" && i + 1 < argc) threads = std::atoi(argv[++i]);
    else if (a == "--surrogate" && i + 1 < argc) surrogate = argv[++i];
    else if (a == "--only" && i + 1 < argc) only = argv[++i];
    else if (a == "--first-seed" && i + 1 < argc) first_seed = std::atoi(argv[++i]);
    else {
      std::fprintf(stderr, "usage: %s [--seeds N] [--threads N] [--surrogate gp|vhgp] [--only NAME-PREFIX] [--first-seed K]\n", argv[0]);
      return 2;
    }
  }
  set_log_level(LogLevel::Error);
  Registry& reg = default_registry();
  const std::string tmp = (std::filesystem::temp_directory_path() / fmt::format("varbo_bench_output_transform_{}", getpid())).string();
  // exp(Branin/20): costs from 1.02 to ~5e6 on the box, minimum exp(0.397887/20) at Branin's three minimizers.
  const std::string exp_branin_task =
      "{type: external, input: args, lower: [-5, 0], upper: [10, 15], command: \"awk 'BEGIN { pi = atan2(0, -1); "
      "x = ARGV[1]; y = ARGV[2]; t = y - 5.1/(4*pi*pi)*x*x + 5/pi*x - 6; "
      "printf \\\"%.17g\\\\n\\\", exp((t*t + 10*(1 - 1/(8*pi))*cos(x) + 10)/20) }'\"}";
  const std::vector<Problem> problems = {
      {"Rosenbrock-2 [-5,10]^2", "{type: rosenbrock, dim: 2}", 50, nullptr},
      {"Rosenbrock-5 [-5,10]^5", "{type: rosenbrock, dim: 5}", 100, nullptr},
      {"exp(Branin/20)", exp_branin_task, 50,
       [](const Vec& t) { return std::exp(branin(t(0), t(1)) / 20); }, std::exp(5 / (4 * M_PI) / 20)},
      {"Branin", "{type: branin}", 50, nullptr},
      {"Hartmann-6", "{type: hartmann6}", 100, nullptr},
      // Noisy (additive Gaussian): does warping hurt when the noise, not the scale, is the difficulty?
      {"noisy Branin (sd 2)", "{type: branin, noise_std: 2}", 50, nullptr},
      {"noisy Hartmann-3 (sd 0.1)", "{type: hartmann3, noise_std: 0.1}", 50, nullptr},
  };
  std::printf("surrogate: %s; algorithm {type: bo} defaults; seeds %d-%d; threads %d\n\n", surrogate.c_str(),
              first_seed, first_seed + seeds - 1, threads);
  std::printf("| problem | budget | recommended: none | recommended: yeo_johnson | yj wins/ties/losses | "
              "best observed: none | best observed: yeo_johnson | s/run none, yj |\n|---|---|---|---|---|---|---|---|\n");
  for (const Problem& p : problems) {
    if (!only.empty() && p.name.rfind(only, 0) != 0) continue;  // prefix match
    std::vector<double> rec[2], best[2], secs[2];
    int wins = 0, ties = 0, losses = 0;
    for (int seed = first_seed; seed < first_seed + seeds; ++seed) {
      Outcome o[2];
      for (int k = 0; k < 2; ++k) {
        const std::string tr = k == 0 ? "none" : "yeo_johnson";
        o[k] = run(p, surrogate, tr, seed, threads, reg, fmt::format("{}/{}_{}_{}", tmp, p.name.substr(0, 8), tr, seed));
        rec[k].push_back(o[k].recommended);
        best[k].push_back(o[k].best);
        secs[k].push_back(o[k].seconds);
      }
      const double r = (o[1].recommended + 1e-12) / (o[0].recommended + 1e-12);
      (r < 0.9 ? wins : r > 1.1 ? losses : ties)++;
      std::fprintf(stderr, "%s seed %d: recommended %.3g vs %.3g, best %.3g vs %.3g\n", p.name.c_str(), seed,
                   o[0].recommended, o[1].recommended, o[0].best, o[1].best);
    }
    std::printf("| %s | %d | %s | %s | %d/%d/%d | %s | %s | %.0f, %.0f |\n", p.name.c_str(), p.budget,
                summary(rec[0]).c_str(), summary(rec[1]).c_str(), wins, ties, losses, summary(best[0]).c_str(),
                summary(best[1]).c_str(), quantile(secs[0], 0.5), quantile(secs[1], 0.5));
    std::fflush(stdout);
  }
  return 0;
}
