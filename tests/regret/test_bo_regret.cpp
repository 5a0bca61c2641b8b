// Issue 2's end-to-end targets, checked on the configuration the README's table is made with
// (bench/e2e/bench_bo_table.cpp: defaults + a final 20-evaluation exploitation phase), seeds 1–10, budget 100,
// 10 initial points: median simple regret at most the reference library's (Branin 2e-5, Hartmann-3 3e-5,
// Hartmann-6 2e-5, Ackley-5 0.2) and the Hartmann-6 upper quartile under 0.05.
//
// The Hartmann-6 quartile is the fragile one: about 30 % of seeds stay in a local minimum (6 of seeds 1–20, 2 of
// seeds 1–10, README), and the quartile is under 0.05 only with at most 2 stuck runs of 10. If a change moves one
// more seed into the local minimum this check fails; that is a real change in behaviour worth looking at.
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "bo_table_config.hpp"
#include "study_helpers.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {

using bench::kTableAlgorithm;
using bench::quantile;

std::vector<double> regrets(const std::string& name, const std::string& task) {
  std::vector<double> r;
  for (int seed = 1; seed <= 10; ++seed) {
    RunOverrides ov;
    ov.output = test::temp_folder("bo_regret_" + name + "_" + std::to_string(seed));
    ov.threads = 2;
    const RunSummary s = test::run_yaml(
        "task: " + task + "\nbudget: 100\nseed: " + std::to_string(seed) + "\nalgorithm: " + kTableAlgorithm + "\n",
        test::registry(), ov);
    REQUIRE(s.evaluations == 100);
    REQUIRE(s.regret_best_observed.has_value());
    r.push_back(*s.regret_best_observed);  // the reference library's figure: best observed (noise-free here)
  }
  std::printf("%-10s regret@100 median %.3g [q1 %.3g, q3 %.3g]\n", name.c_str(), quantile(r, 0.5), quantile(r, 0.25),
              quantile(r, 0.75));
  return r;
}

}  // namespace

TEST_CASE("GP-BO regret after 100 evaluations meets the reference medians (10 seeds)") {
  CHECK(quantile(regrets("branin", "{type: branin}"), 0.5) <= 2e-5);
  CHECK(quantile(regrets("hartmann3", "{type: hartmann3}"), 0.5) <= 3e-5);
  const std::vector<double> h6 = regrets("hartmann6", "{type: hartmann6}");
  CHECK(quantile(h6, 0.5) <= 2e-5);
  CHECK(quantile(h6, 0.75) < 0.05);
  CHECK(quantile(regrets("ackley5", "{type: ackley, dim: 5, bounds: [-5, 10]}"), 0.5) <= 0.2);
}
