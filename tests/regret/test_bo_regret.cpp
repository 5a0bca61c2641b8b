// Issue 13's end-to-end targets, checked on the configuration the README's table is made with: the plain default
// `{type: bo}` (bench/e2e/bo_table_config.hpp), budget 100, seeds 1–20, regret of the *recommended* θ (what a
// user deploys; the tasks are noise-free, so it is summary.json's regret_recommended).
//
// Met and guarded: median ≤ 1e-8 on Branin and Hartmann-3 (7.5e-10 and 2.4e-10 since session h6b's defaults;
// guarded at 1e-9), ≤ 0.05 on Ackley-5 on [−5, 10]^5 (0.036); Hartmann-6's upper quartile < 0.01 (0.0023: 3 of
// seeds 1–20 stay in the local minimum at regret 0.119) and, since session h6med's early refinement
// (`refine_early`), its median ≤ 1e-6 (6.4e-07: 11 of the 20 runs at 1e-6, the 10th and 11th at 5.1e-07 and
// 7.6e-07; docs/defaults.md). Guarded exactly at the target, with at least 11 of 20 runs at 1e-6 — one run fewer
// would be a real change in behaviour worth looking at. And SE-ARD given alone within 3× of Matérn-5/2 (below).
#include <algorithm>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "bo_table_config.hpp"
#include "study_helpers.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {

using bench::kTableAlgorithm;
using bench::quantile;

std::vector<double> regrets(const std::string& name, const std::string& task,
                            const std::string& algorithm = kTableAlgorithm) {
  std::vector<double> r;
  for (int seed = 1; seed <= 20; ++seed) {
    RunOverrides ov;
    ov.output = test::temp_folder("bo_regret_" + name + "_" + std::to_string(seed));
    ov.threads = 2;
    const RunSummary s = test::run_yaml(
        "task: " + task + "\nbudget: 100\nseed: " + std::to_string(seed) + "\nalgorithm: " + algorithm + "\n",
        test::registry(), ov);
    REQUIRE(s.evaluations == 100);
    REQUIRE(s.regret_recommended.has_value());
    r.push_back(*s.regret_recommended);
  }
  std::printf("%-14s recommended regret@100 median %.3g [q1 %.3g, q3 %.3g]\n", name.c_str(), quantile(r, 0.5),
              quantile(r, 0.25), quantile(r, 0.75));
  return r;
}

}  // namespace

TEST_CASE("the plain default's recommended regret after 100 evaluations (seeds 1-20)") {
  CHECK(quantile(regrets("branin", "{type: branin}"), 0.5) <= 1e-9);
  CHECK(quantile(regrets("hartmann3", "{type: hartmann3}"), 0.5) <= 1e-9);
  CHECK(quantile(regrets("ackley5", "{type: ackley, dim: 5, bounds: [-5, 10]}"), 0.5) <= 0.05);
  const std::vector<double> h6 = regrets("hartmann6", "{type: hartmann6}");
  CHECK(quantile(h6, 0.5) <= 1e-6);
  CHECK(quantile(h6, 0.75) < 0.01);
  CHECK(std::count_if(h6.begin(), h6.end(), [](double r) { return r <= 1e-6; }) >= 11);
}

TEST_CASE("SE-ARD within 3x of Matern-5/2 with otherwise plain defaults (seeds 1-20)") {
  // Issue 13: `kernel: se_ard` given alone (with it, by default since session 17, the gp's noise test and bo's
  // replicated design point) against `kernel: matern52_ard`, the medians of the recommended regret. Measured
  // (docs/defaults.md, "Session 17"): Branin 0.11x, Hartmann-3 0.46x, Hartmann-6 1.9x, Ackley-5 2.1x.
  const std::string se = "{type: bo, surrogate: {type: gp, kernel: se_ard}}";
  const std::string matern = "{type: bo, surrogate: {type: gp, kernel: matern52_ard}}";
  const std::vector<std::pair<std::string, std::string>> problems = {
      {"branin", "{type: branin}"},
      {"hartmann3", "{type: hartmann3}"},
      {"hartmann6", "{type: hartmann6}"},
      {"ackley5", "{type: ackley, dim: 5, bounds: [-5, 10]}"}};
  for (const auto& [name, task] : problems) {
    CAPTURE(name);
    const double m_se = quantile(regrets(name + "_se", task, se), 0.5);
    const double m_matern = quantile(regrets(name + "_matern", task, matern), 0.5);
    CHECK(m_se <= 3 * m_matern);
  }
}
