// Tests of `varbo rescore`'s library (framework/src/rescore.cpp) on a real RSSGD run of the gantry transport
// task: re-scoring with unchanged weights reproduces the recorded costs; new weights give Σ w·components;
// the offline risk objective's gradient matches finite differences; κ-selections stay in the ε-ball and a
// larger κ never selects a larger predicted std; a continuation runs under the new weights.
#include <cmath>
#include <fmt/format.h>

#include "study_helpers.hpp"
#include "varbo/errors.hpp"
#include "varbo/log.hpp"
#include "varbo/math.hpp"
#include "varbo/rescore.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {
const ComponentRun& learned_run() {
  static const ComponentRun run = [] {
    set_log_level(LogLevel::Warn);
    const std::string out = test::temp_folder("rescore_run");
    test::run_yaml(fmt::format("task: {{type: cartpole_transport}}\nbudget: 24\nseed: 5\noutput: {}\n"
                               "algorithm: {{type: rssgd, critic: {{type: vhgp, restarts: 2}}}}\n",
                               out),
                   test::registry());
    return load_component_run(out, test::registry());
  }();
  return run;
}
}  // namespace

TEST_CASE("re-scoring with the run's own weights reproduces every recorded cost") {
  const ComponentRun& run = learned_run();
  REQUIRE(run.cost.size() == 24);
  CHECK(run.components == std::vector<std::string>{"tracking", "sway", "energy"});
  CHECK(run.weights.at("energy") == 0.002);  // the task's default `weights`, read from config.resolved.yaml
  const Vec again = rescore_costs(run, run.weights);
  // Same products summed in the same order as the task: equal to the last bit; stated tolerance 1e-12 relative.
  const double err = ((again - run.cost).array().abs() / run.cost.array().abs()).maxCoeff();
  MESSAGE("max relative difference " << err);
  CHECK(err <= 1e-12);
  REQUIRE(run.recommended.has_value());
  REQUIRE(run.initial_point.has_value());
}

TEST_CASE("new weights give the weighted sum of the recorded components (eq. 23)") {
  const ComponentRun& run = learned_run();
  const Weights w = merge_weights(run.weights, parse_weight_list("energy=0.05,sway=0", run.components));
  CHECK(w.at("tracking") == 0.25);
  CHECK(w.at("sway") == 0.0);
  const Vec c = rescore_costs(run, w);
  for (Index i = 0; i < c.size(); ++i) CHECK(c[i] == doctest::Approx(0.25 * run.values(i, 0) + 0.05 * run.values(i, 2)));
  CHECK_THROWS_AS(parse_weight_list("power=1", run.components), InputError);
  CHECK_THROWS_AS(parse_weight_list("energy", run.components), InputError);
  CHECK_THROWS_AS(parse_weight_list("energy=-1", run.components), InputError);
  CHECK(parse_weight_list("", run.components).empty());
}

TEST_CASE("the offline risk objective's gradient matches central differences") {
  const ComponentRun& run = learned_run();
  const Vec costs = rescore_costs(run, merge_weights(run.weights, {{"energy", 0.02}}));
  OfflineSelectionSettings s = offline_settings_from(run, test::registry());
  LocalModel m;
  const Vec centre = to_unit(*run.recommended, run.domain.box);
  select_offline(run, costs, centre, {0.0}, s, test::registry(), &m);
  REQUIRE(m.critic);
  for (double kappa : {0.0, 2.0, -1.0}) {
    const RiskObjective f(*m.critic, kappa, centre.size());
    Rng rng(3);
    const Vec x = Box::unit(centre.size()).clamp(centre + 0.05 * rng.normal_vec(centre.size()));
    const GradientCheck g = check_gradient(f, x, 1e-6);
    CAPTURE(kappa);
    MESSAGE("kappa " << kappa << ": max relative gradient error " << g.max_rel_error);
    CHECK(g.max_rel_error < 1e-4);  // stated tolerance for h = 1e-6 central differences
  }
}

TEST_CASE("kappa selections lie in the epsilon-ball, and a larger kappa never selects a larger predicted std") {
  const ComponentRun& run = learned_run();
  const Vec costs = rescore_costs(run, merge_weights(run.weights, {{"energy", 0.02}}));
  const OfflineSelectionSettings s = offline_settings_from(run, test::registry());
  CHECK(s.radius == doctest::Approx(3.5 * 0.075));  // the run's rssgd ε
  const Vec centre = to_unit(*run.recommended, run.domain.box);
  const auto sel = select_offline(run, costs, centre, {0.0, 2.0}, s, test::registry());
  REQUIRE(sel.size() == 2);
  for (const auto& x : sel) {
    CHECK((x.unit - centre).norm() <= s.radius + 1e-6);
    CHECK(Box::unit(centre.size()).contains(x.unit));
    CHECK((x.theta - from_unit(x.unit, run.domain.box)).norm() <= 1e-12);
  }
  // If both are minimizers, J(x2) + 2r(x2) <= J(x0) + 2r(x0) and J(x0) <= J(x2) give r(x2) <= r(x0).
  CHECK(sel[1].std <= sel[0].std + 1e-6);
  CHECK(sel[0].mean <= sel[1].mean + 1e-6);
}

TEST_CASE("--continue runs RSSGD steps from the selected policy under the new weights") {
  const ComponentRun& run = learned_run();
  const Weights w = merge_weights(run.weights, {{"energy", 0.02}});
  const Vec costs = rescore_costs(run, w);
  const Vec start = *run.recommended;
  const std::string folder = test::temp_folder("rescore_continue") + "/continue_1";
  const RunSummary s = continue_with_rssgd(run, w, costs, start, 2.0, 3, folder, 9, test::registry());
  CHECK(s.evaluations == 3);
  const ComponentRun cont = load_component_run(folder, test::registry());
  CHECK(cont.weights.at("energy") == 0.02);
  CHECK(cont.study.algorithm.options.real("kappa") == 2.0);
  // The continued trials are costed with the new weights.
  const Vec again = rescore_costs(cont, w);
  CHECK(((again - cont.cost).array().abs()).maxCoeff() <= 1e-12 * (1 + cont.cost.cwiseAbs().maxCoeff()));
  REQUIRE(cont.initial_point.has_value());
  CHECK((*cont.initial_point - start).norm() <= 1e-12);
  // A folder without config.resolved.yaml is not a run.
  CHECK_THROWS_AS(load_component_run(test::temp_folder("not_a_run"), test::registry()), InputError);
}
