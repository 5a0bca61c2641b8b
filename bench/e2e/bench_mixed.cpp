// Typed search spaces (docs/search_space.md): the regret of the recommended θ on the mixed benchmarks of
// tasks/benchmarks, for bo (plain defaults: the surrogate sees integers and categories rounded), random search,
// and bo with `discrete: relax` ("treat everything as continuous and round at evaluation") on the problems with
// integer or categorical parameters. Also counts inadmissible trials (type, bounds, constraints): must be 0.
//
//   nice -n 15 build/bin/bench_mixed [--seeds 10] [--first-seed 1] [--budget 100] [--threads 1] [--only NAME]
//                                    [--surrogate YAML]   (given to both bo methods, e.g. '{type: gp, kernel: matern52_ard}')
//
// Prints a Markdown table: median [q1, q3] over the seeds.
#include <fmt/format.h>

#include <cstdio>
#include <cstdlib>
#include <unistd.h>
#include <filesystem>
#include <string>
#include <vector>

#include "bo_table_config.hpp"
#include "varbo/loader.hpp"
#include "varbo/log.hpp"
#include "varbo/study.hpp"
#include "varbo/study_api.hpp"

using namespace varbo;
using varbo::bench::quantile;

namespace {

struct Problem {
  std::string task;
  bool discrete;
};
const std::vector<Problem> kProblems = {
    {"mixed_ackley", true}, {"integer_rosenbrock", true}, {"log_scale", false}, {"branin_constrained", false}};

struct Method {
  std::string name, yaml;
  bool only_discrete;
};
const std::vector<Method> kMethods = {{"bo", "{type: bo}", false},
                                      {"bo, relax + round", "{type: bo, discrete: relax}", true},
                                      {"random", "{type: random}", false}};

std::string cell(const std::vector<double>& v) {
  return fmt::format("{:.3g} [{:.3g}, {:.3g}]", quantile(v, 0.5), quantile(v, 0.25), quantile(v, 0.75));
}

}  // namespace

int main(int argc, char** argv) {
  int seeds = 10, first_seed = 1, budget = 100, threads = 1;
  std::string only, surrogate;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--seeds" && i + 1 < argc) seeds = std::atoi(argv[++i]);
    else if (a == "--first-seed" && i + 1 < argc) first_seed = std::atoi(argv[++i]);
    else if (a == "--budget" && i + 1 < argc) budget = std::atoi(argv[++i]);
    else if (a == "--threads" && i + 1 < argc) threads = std::atoi(argv[++i]);
    else if (a == "--only" && i + 1 < argc) only = argv[++i];
    else if (a == "--surrogate" && i + 1 < argc) surrogate = argv[++i];
    else {
      std::fprintf(stderr, "usage: %s [--seeds N] [--first-seed S] [--budget B] [--threads N] [--only TASK] [--surrogate YAML]\n", argv[0]);
      return 2;
    }
  }
  set_log_level(LogLevel::Warn);
  Registry registry;
  PluginLoader loader(registry);
  loader.load_default({});
  const std::string root = (std::filesystem::temp_directory_path() / fmt::format("varbo_bench_mixed_{}", getpid())).string();
  std::printf("| problem | method | regret of the recommended θ, median [q1, q3] | inadmissible trials |\n|---|---|---|---|\n");
  for (const Problem& p : kProblems) {
    if (!only.empty() && only != p.task) continue;
    for (const Method& m : kMethods) {
      if (m.only_discrete && !p.discrete) continue;
      std::vector<double> regret;
      long inadmissible = 0;
      for (int s = first_seed; s < first_seed + seeds; ++s) {
        RunOverrides ov;
        ov.progress = false;
        ov.threads = threads;
        ov.output = fmt::format("{}/{}_{}_{}", root, p.task, m.only_discrete ? "relax" : m.name, s);
        std::string algorithm = m.yaml;
        if (!surrogate.empty() && algorithm.rfind("{type: bo", 0) == 0)
          algorithm = algorithm.substr(0, algorithm.size() - 1) + ", surrogate: " + surrogate + "}";
        const std::string yaml =
            fmt::format("task: {}\nbudget: {}\nseed: {}\nalgorithm: {}\n", p.task, budget, s, algorithm);
        const StudyConfig cfg = parse_study(ConfigNode::parse(yaml, "<bench_mixed>"), registry);
        const RunSummary sum = run_study(cfg, registry, ov);
        regret.push_back(sum.regret_recommended.value_or(NAN));
        Study st = Study::attach(*ov.output + "/study.db", cfg, registry);
        for (const auto& t : st.trials())
          if (!st.space()->contains(t.theta)) ++inadmissible;
        std::filesystem::remove_all(*ov.output);
        std::fprintf(stderr, "%s %s seed %d: regret %.3g\n", p.task.c_str(), m.name.c_str(), s, regret.back());
      }
      std::printf("| %s | %s | %s | %ld |\n", p.task.c_str(), m.name.c_str(), cell(regret).c_str(), inadmissible);
      std::fflush(stdout);
    }
  }
  std::filesystem::remove_all(root);
  return 0;
}
