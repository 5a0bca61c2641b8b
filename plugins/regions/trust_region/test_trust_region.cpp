#include <limits>
#include <sstream>

#include "trust_region.hpp"
#include "varbo/errors.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {
// Appends a point with the given cost and updates the region, as the bo algorithm does after each fit.
void observe(TrustRegion& tr, Dataset& data, const Vec& x, double cost) {
  data.add(x, cost);
  Rng rng(0);
  tr.update(nullptr, data, rng);
}
}  // namespace

TEST_CASE("trust_region: defaults follow Eriksson et al. 2019") {
  TrustRegion tr(10, {});
  CHECK(tr.length() == 0.8);
  CHECK(tr.failure_tolerance() == 10);  // ceil(max(4, 10))
  TrustRegion small(2, {});
  CHECK(small.failure_tolerance() == 4);  // ceil(max(4, 2))
  // With batches of q the tolerance counts batches: ceil(max(4/q, d/q)) (mutation testing, session 31: dropping
  // the /q on d survived every test, and the region shrank 3× too slowly at d = 10, q = 4).
  TrustRegionOptions batched;
  batched.batch_size = 4;
  CHECK(TrustRegion(10, batched).failure_tolerance() == 3);  // ceil(max(1, 2.5))
  CHECK(TrustRegion(2, batched).failure_tolerance() == 1);   // ceil(max(1, 0.5))
  CHECK_FALSE(tr.has_constraint());
  CHECK(tr.bounds().lower.isApprox(Vec::Zero(10)));  // before data: the unit cube
}

TEST_CASE("trust_region: scripted successes double L, failures halve it, collapse restarts") {
  TrustRegionOptions keep;
  keep.restart_center = "incumbent";
  TrustRegion tr(2, keep);
  Dataset data = Dataset::empty(2);
  observe(tr, data, (Vec(2) << 0.5, 0.5).finished(), 10.0);  // initial design: reference only
  CHECK(tr.length() == 0.8);
  // The box is centred on the incumbent and clipped to the unit cube.
  CHECK(tr.bounds().lower.isApprox(Vec::Constant(2, 0.1)));
  CHECK(tr.bounds().upper.isApprox(Vec::Constant(2, 0.9)));
  // Three successes (each improves by more than 1e-3·|best|) double L.
  observe(tr, data, (Vec(2) << 0.6, 0.5).finished(), 9.0);
  observe(tr, data, (Vec(2) << 0.7, 0.5).finished(), 8.0);
  CHECK(tr.successes() == 2);
  observe(tr, data, (Vec(2) << 0.8, 0.5).finished(), 7.0);
  CHECK(tr.length() == doctest::Approx(1.6));
  CHECK(tr.successes() == 0);
  CHECK(tr.center().isApprox((Vec(2) << 0.8, 0.5).finished()));
  CHECK(tr.bounds().upper[0] == 1.0);  // clipped
  CHECK(tr.bounds().lower[0] == doctest::Approx(0.0));
  // A tiny improvement (< 1e-3 relative) is a failure; 4 failures halve L.
  observe(tr, data, (Vec(2) << 0.1, 0.1).finished(), 6.9999);
  observe(tr, data, (Vec(2) << 0.2, 0.1).finished(), 50.0);
  observe(tr, data, (Vec(2) << 0.3, 0.1).finished(), 50.0);
  CHECK(tr.failures() == 3);
  observe(tr, data, (Vec(2) << 0.4, 0.1).finished(), 50.0);
  CHECK(tr.length() == doctest::Approx(0.8));
  CHECK(tr.failures() == 0);
  // The incumbent moved to the (slightly) better point.
  CHECK(tr.center().isApprox((Vec(2) << 0.1, 0.1).finished()));
  // A success resets the failure counter.
  observe(tr, data, (Vec(2) << 0.5, 0.1).finished(), 50.0);
  observe(tr, data, (Vec(2) << 0.15, 0.1).finished(), 1.0);
  CHECK(tr.failures() == 0);
  CHECK(tr.successes() == 1);
  // Halving 0.8 seven times gives 0.00625 < 0.5^7: the 7th halving restarts.
  int halvings = 0;
  while (tr.restarts() == 0 && halvings < 20) {
    for (int k = 0; k < 4; ++k) observe(tr, data, (Vec(2) << 0.9, 0.9).finished(), 100.0);
    ++halvings;
  }
  CHECK(halvings == 7);
  CHECK(tr.restarts() == 1);
  CHECK(tr.length() == 2.0);  // restart_length: the whole unit cube
  CHECK(data.size() == 10 + 28);  // data kept
  CHECK(tr.center().isApprox((Vec(2) << 0.15, 0.1).finished()));
}

TEST_CASE("trust_region: an update without new data changes nothing; bad lengths are a ConfigError") {
  TrustRegion tr(2, {});
  Dataset data = Dataset::empty(2);
  observe(tr, data, (Vec(2) << 0.5, 0.5).finished(), 1.0);
  observe(tr, data, (Vec(2) << 0.6, 0.5).finished(), 2.0);
  CHECK(tr.failures() == 1);
  Rng rng(0);
  tr.update(nullptr, data, rng);  // a refit without new observations
  CHECK(tr.failures() == 1);
  TrustRegionOptions bad;
  bad.length_min = 1.0;
  CHECK_THROWS_AS(TrustRegion(2, bad), ConfigError);
}

TEST_CASE("trust_region: registered as a box region") {
  BuildContext ctx;
  ctx.dim = 3;
  auto r = test::registry().create<RegionConstraint>("{type: trust_region, length_init: 0.4}", ctx);
  CHECK_FALSE(r->has_constraint());
  Dataset data = Dataset::empty(3);
  data.add(Vec::Constant(3, 0.5), 1.0);
  Rng rng(0);
  r->update(nullptr, data, rng);
  CHECK((r->bounds().upper - r->bounds().lower).isApprox(Vec::Constant(3, 0.4)));
}

TEST_CASE("trust_region: restart_length sets L after a collapse; 2 makes the box the whole unit cube") {
  TrustRegionOptions o;
  o.restart_center = "incumbent";
  o.restart_length = 2.0;
  o.failure_tolerance = 1;
  TrustRegion tr(2, o);
  Dataset data = Dataset::empty(2);
  observe(tr, data, (Vec(2) << 0.9, 0.95).finished(), 1.0);  // the incumbent, near a corner
  // Each failure halves L (τ_fail = 1): 0.8 → 0.4 → ... → 0.00625 < 0.5^7 restarts on the 7th.
  for (int k = 0; k < 7; ++k) observe(tr, data, (Vec(2) << 0.1 * k, 0.1).finished(), 5.0);
  CHECK(tr.restarts() == 1);
  CHECK(tr.length() == 2.0);
  CHECK(tr.bounds().lower.isApprox(Vec::Zero(2)));
  CHECK(tr.bounds().upper.isApprox(Vec::Ones(2)));
  CHECK(tr.center().isApprox((Vec(2) << 0.9, 0.95).finished()));
  // The next failure halves it back to a box of side 1 around the incumbent, clipped.
  observe(tr, data, (Vec(2) << 0.5, 0.5).finished(), 5.0);
  CHECK(tr.length() == 1.0);
  CHECK(tr.bounds().lower.isApprox((Vec(2) << 0.4, 0.45).finished()));
}

TEST_CASE("trust_region: a side cap (bo's failure_model.length_max) bounds L; lifting it restores the doubling") {
  TrustRegionOptions keep;
  keep.restart_center = "incumbent";
  TrustRegion tr(2, keep);
  Dataset data = Dataset::empty(2);
  observe(tr, data, (Vec(2) << 0.5, 0.5).finished(), 10.0);
  // Three successes would double L to 1.6 (the test above); with a cap of 0.8 L stays 0.8, the count resets.
  tr.set_side_cap(0.8);
  for (double c : {9.0, 8.0, 7.0}) observe(tr, data, (Vec(2) << 0.5 + 0.01 * (10 - c), 0.5).finished(), c);
  CHECK(tr.length() == doctest::Approx(0.8));
  CHECK(tr.successes() == 0);
  CHECK(tr.bounds().upper[0] - tr.bounds().lower[0] == doctest::Approx(0.8));
  // Without the cap the next three double it, and a cap set later shrinks it at the next update, whatever
  // that update counts (here one more success).
  tr.set_side_cap(std::numeric_limits<double>::infinity());
  for (double c : {6.0, 5.0, 4.0}) observe(tr, data, (Vec(2) << 0.5 + 0.01 * (10 - c), 0.5).finished(), c);
  CHECK(tr.length() == doctest::Approx(1.6));
  tr.set_side_cap(0.5);
  observe(tr, data, (Vec(2) << 0.6, 0.5).finished(), 3.0);
  CHECK(tr.length() == doctest::Approx(0.5));
  CHECK(tr.bounds().lower.isApprox((Vec(2) << 0.35, 0.25).finished()));
  CHECK(tr.bounds().upper.isApprox((Vec(2) << 0.85, 0.75).finished()));
  // A cap below length_min is held at length_min: the region does not restart at every update.
  tr.set_side_cap(1e-6);
  observe(tr, data, (Vec(2) << 0.6, 0.6).finished(), 2.0);
  CHECK(tr.length() == doctest::Approx(TrustRegionOptions{}.length_min));
  CHECK(tr.restarts() == 0);
  // The cap is not part of the saved state: a restored region has the very box.
  TrustRegion copy(2, keep);
  copy.restore_state(tr.save_state());
  CHECK(copy.bounds().lower.isApprox(tr.bounds().lower));
  CHECK(copy.length() == tr.length());
}

TEST_CASE("trust_region: restart_center new_points restarts afresh around the points found since the restart") {
  TrustRegionOptions o;
  o.restart_center = "new_points";
  o.failure_tolerance = 1;
  TrustRegion tr(2, o);
  CHECK(tr.fresh_starts() == 0);
  Dataset data = Dataset::empty(2);
  observe(tr, data, (Vec(2) << 0.9, 0.95).finished(), 1.0);  // the incumbent of all the data
  for (int k = 0; k < 7; ++k) observe(tr, data, (Vec(2) << 0.1 * k, 0.1).finished(), 5.0);
  CHECK(tr.restarts() == 1);
  CHECK(tr.fresh_starts() == 1);  // the algorithm is asked for a new design and a model of the new points
  CHECK(tr.length() == doctest::Approx(o.length_init));
  // The new design: every point worse than the old incumbent. The box centres on the best new point (not on
  // the incumbent at (0.9, 0.95)), and the first update after the restart only sets the reference.
  data.add((Vec(2) << 0.2, 0.3).finished(), 4.0);
  data.add((Vec(2) << 0.6, 0.7).finished(), 3.0);
  Rng rng(0);
  tr.update(nullptr, data, rng);
  CHECK(tr.center().isApprox((Vec(2) << 0.6, 0.7).finished()));
  CHECK(tr.failures() == 0);
  CHECK(tr.successes() == 0);
  // Successes are counted against the best new point: 2.5 < 3 is one, although the incumbent is 1.
  observe(tr, data, (Vec(2) << 0.55, 0.7).finished(), 2.5);
  CHECK(tr.successes() == 1);
  CHECK(tr.center().isApprox((Vec(2) << 0.55, 0.7).finished()));
  // The snapshot carries the restart: a restored region continues identically.
  TrustRegion copy(2, o);
  copy.restore_state(tr.save_state());
  observe(tr, data, (Vec(2) << 0.5, 0.7).finished(), 2.0);
  copy.update(nullptr, data, rng);
  CHECK(copy.center() == tr.center());
  CHECK(copy.successes() == tr.successes());
  CHECK(copy.fresh_starts() == 1);
  // restart_center: incumbent never asks for a fresh start.
  TrustRegionOptions d;
  d.restart_center = "incumbent";
  d.failure_tolerance = 1;
  TrustRegion plain(2, d);
  Dataset pd = Dataset::empty(2);
  for (int k = 0; k < 9; ++k) observe(plain, pd, (Vec(2) << 0.1 * k, 0.1).finished(), k == 0 ? 1.0 : 5.0);
  CHECK(plain.restarts() == 1);
  CHECK(plain.fresh_starts() == 0);
}

TEST_CASE("trust_region: return_to_incumbent ends the fresh starts: a small box around the incumbent of all the data") {
  TrustRegionOptions o;
  o.restart_center = "new_points";
  o.failure_tolerance = 1;
  o.length_min = 0.05;
  TrustRegion tr(2, o);
  Dataset data = Dataset::empty(2);
  observe(tr, data, (Vec(2) << 0.9, 0.95).finished(), 1.0);
  for (int k = 0; k < 5; ++k) observe(tr, data, (Vec(2) << 0.1 * k, 0.1).finished(), 5.0);  // 0.8 → 0.025
  REQUIRE(tr.fresh_starts() == 1);
  observe(tr, data, (Vec(2) << 0.3, 0.3).finished(), 4.0);  // the new design's best
  CHECK(tr.center().isApprox((Vec(2) << 0.3, 0.3).finished()));
  tr.return_to_incumbent();
  tr.return_to_incumbent();  // idempotent
  CHECK(tr.returned());
  CHECK(tr.length() == doctest::Approx(0.2));  // length_init / 4
  observe(tr, data, (Vec(2) << 0.35, 0.3).finished(), 4.5);
  CHECK(tr.center().isApprox((Vec(2) << 0.9, 0.95).finished()));  // the incumbent of all the data
  // Failures shrink the box down to length_min, never below, and never restart again.
  for (int k = 0; k < 10; ++k) observe(tr, data, (Vec(2) << 0.5, 0.02 * k).finished(), 5.0);
  CHECK(tr.length() == doctest::Approx(0.05));
  CHECK(tr.fresh_starts() == 1);
  CHECK(tr.restarts() == 1);
}

TEST_CASE("trust_region: stall_tolerance consecutive failures next to the incumbent restart at once") {
  TrustRegionOptions o;  // a fresh start after 3 stalls within 1e-3 of the incumbent
  o.restart_center = "new_points";
  o.stall_tolerance = 3;
  TrustRegion tr(2, o);
  Dataset data = Dataset::empty(2);
  const Vec inc = (Vec(2) << 0.4, 0.6).finished();
  observe(tr, data, inc, 1.0);
  // Failures far from the incumbent are no stalls.
  observe(tr, data, (Vec(2) << 0.1, 0.1).finished(), 2.0);
  CHECK(tr.failures() == 1);
  CHECK(tr.stalls() == 0);
  // Two stalls, then a failure farther than 1e-3 resets the count.
  observe(tr, data, inc + Vec::Constant(2, 5e-4), 1.0);
  observe(tr, data, inc - Vec::Constant(2, 5e-4), 1.0);
  CHECK(tr.stalls() == 2);
  observe(tr, data, inc + Vec::Constant(2, 2e-3), 1.0);
  CHECK(tr.stalls() == 0);
  CHECK(tr.restarts() == 0);
  // Three in a row: converged there, a fresh start although L (0.8) is far above length_min.
  for (int k = 0; k < 3; ++k) observe(tr, data, inc + Vec::Constant(2, 1e-4 * k), 1.0);
  CHECK(tr.restarts() == 1);
  CHECK(tr.fresh_starts() == 1);
  CHECK(tr.stalls() == 0);
  // Off (−1): the same stalls only count as failures.
  TrustRegionOptions off;
  off.restart_center = "new_points";
  off.stall_tolerance = -1;
  TrustRegion plain(2, off);
  Dataset pd = Dataset::empty(2);
  observe(plain, pd, inc, 1.0);
  for (int k = 0; k < 3; ++k) observe(plain, pd, inc + Vec::Constant(2, 1e-4 * k), 1.0);
  CHECK(plain.restarts() == 0);
  CHECK(plain.failures() == 3);
}

TEST_CASE("trust_region: stall_count since_success keeps stalls across failures away from the incumbent") {
  TrustRegionOptions o;
  o.restart_center = "new_points";
  o.stall_tolerance = 3;
  o.stall_count = "since_success";
  TrustRegion tr(2, o);
  Dataset data = Dataset::empty(2);
  const Vec inc = (Vec(2) << 0.4, 0.6).finished();
  observe(tr, data, inc, 1.0);
  // Stall, a probe far away (a failure, no stall), stall: the count is 2, not 1 as with `consecutive`.
  observe(tr, data, inc + Vec::Constant(2, 5e-4), 1.0);
  observe(tr, data, (Vec(2) << 0.1, 0.1).finished(), 2.0);
  observe(tr, data, inc - Vec::Constant(2, 5e-4), 1.0);
  CHECK(tr.stalls() == 2);
  // A success resets it.
  const Vec better = (Vec(2) << 0.45, 0.6).finished();
  observe(tr, data, better, 0.5);
  CHECK(tr.stalls() == 0);
  observe(tr, data, better + Vec::Constant(2, 1e-4), 0.5);
  observe(tr, data, (Vec(2) << 0.9, 0.1).finished(), 2.0);
  observe(tr, data, (Vec(2) << 0.1, 0.9).finished(), 2.0);
  CHECK(tr.restarts() == 0);
  observe(tr, data, better - Vec::Constant(2, 1e-4), 0.5);
  observe(tr, data, better, 0.5);
  // The third stall since the success, with two far failures between: converged, a fresh start.
  CHECK(tr.restarts() == 1);
  CHECK(tr.stalls() == 0);
}

// failh6d: the value stall rule (value_stall.hpp; bo's failure_model.stall_value) on constructed costs.
TEST_CASE("trust_region: value_stall's scales, strict and incumbent rules on a constructed sequence of costs") {
  // An attempt whose costs run from 1.0 (design) down to its best -2.0: range 3, |best| 2.
  const Vec attempt = (Vec(4) << 1.0, 0.0, -1.0, -2.0).finished();
  ValueStall best_rule;
  best_rule.fraction = 1e-3;  // tolerance 1e-3·|−2| = 2e-3
  CHECK(TrustRegion::value_stall(best_rule, -2.0 + 1.9e-3, -2.0, attempt, -2.0));
  CHECK_FALSE(TrustRegion::value_stall(best_rule, -2.0 + 2.1e-3, -2.0, attempt, -2.0));
  CHECK(TrustRegion::value_stall(best_rule, -2.0 - 1e-3, -2.0, attempt, -2.0));  // a tiny improvement counts
  ValueStall off;
  CHECK_FALSE(TrustRegion::value_stall(off, -2.0, -2.0, attempt, -2.0));  // fraction 0: off
  // (a) range: tolerance 1e-3·3 = 3e-3, and the same after shifting every cost by +100 (|best| would be 98).
  ValueStall range = best_rule;
  range.scale = ValueStall::Scale::Range;
  CHECK(TrustRegion::value_stall(range, -2.0 + 2.9e-3, -2.0, attempt, -2.0));
  CHECK_FALSE(TrustRegion::value_stall(range, -2.0 + 3.1e-3, -2.0, attempt, -2.0));
  const Vec shifted = (attempt.array() + 100.0).matrix();
  CHECK(TrustRegion::value_stall(range, 98.0 + 2.9e-3, 98.0, shifted, 98.0));
  CHECK_FALSE(TrustRegion::value_stall(range, 98.0 + 3.1e-3, 98.0, shifted, 98.0));
  CHECK(TrustRegion::value_stall(best_rule, 98.0 + 3e-2, 98.0, shifted, 98.0));  // |best| = 98: 0.098 wide
  // std: the sample standard deviation of {1, 0, −1, −2} is √(5/3) = 1.291.
  ValueStall sd = best_rule;
  sd.scale = ValueStall::Scale::Std;
  CHECK(TrustRegion::value_stall(sd, -2.0 + 1.28e-3, -2.0, attempt, -2.0));
  CHECK_FALSE(TrustRegion::value_stall(sd, -2.0 + 1.30e-3, -2.0, attempt, -2.0));
  // recent (session 19): the range of the last `window` costs only: {−1, −2} spans 1 → tolerance 1e-3; the whole
  // attempt (window 0 or larger than it) is the range rule's 3e-3. A heavy-tailed design cost far back does not
  // widen it.
  ValueStall recent = best_rule;
  recent.scale = ValueStall::Scale::Recent;
  CHECK(TrustRegion::value_stall(recent, -2.0 + 0.9e-3, -2.0, attempt, -2.0, 2));
  CHECK_FALSE(TrustRegion::value_stall(recent, -2.0 + 1.1e-3, -2.0, attempt, -2.0, 2));
  CHECK(TrustRegion::value_stall(recent, -2.0 + 2.9e-3, -2.0, attempt, -2.0, 0));
  CHECK_FALSE(TrustRegion::value_stall(recent, -2.0 + 3.1e-3, -2.0, attempt, -2.0, 9));
  const Vec heavy = (Vec(4) << 1e5, 0.0, -1.0, -2.0).finished();
  CHECK_FALSE(TrustRegion::value_stall(recent, -2.0 + 1.1e-3, -2.0, heavy, -2.0, 2));
  CHECK(TrustRegion::value_stall(range, -2.0 + 1.1e-3, -2.0, heavy, -2.0));  // range: 100 wide
  // (b) strict: a trial that improves the best at all is progress, not a stall; one at or above it is.
  ValueStall strict = range;
  strict.strict = true;
  CHECK_FALSE(TrustRegion::value_stall(strict, -2.0 - 1e-9, -2.0, attempt, -2.0));
  CHECK(TrustRegion::value_stall(strict, -2.0, -2.0, attempt, -2.0));
  CHECK(TrustRegion::value_stall(strict, -2.0 + 1e-3, -2.0, attempt, -2.0));
  // (c) incumbent: the rule applies only while the attempt's best lies more than 0.01·range (0.03) above the
  // best of all the data.
  ValueStall inc = range;
  inc.incumbent = 0.01;
  CHECK_FALSE(TrustRegion::value_stall(inc, -2.0 + 1e-3, -2.0, attempt, -2.0));   // holds the incumbent
  CHECK_FALSE(TrustRegion::value_stall(inc, -2.0 + 1e-3, -2.0, attempt, -2.02));  // within 0.03 of it
  CHECK(TrustRegion::value_stall(inc, -2.0 + 1e-3, -2.0, attempt, -2.1));         // 0.1 above it: cut
}

TEST_CASE("trust_region: a value stall rule ends a converged attempt sooner; strict spares tiny improvements") {
  // Trials after the first: costs of a basin being polished, every point 0.01 apart (never within stall_distance).
  const std::vector<double> costs = {-3.0, -3.0 + 2e-4, -3.0 - 1e-5, -3.0 + 1e-4, -3.0 - 2e-5, -3.0 + 5e-5,
                                     -3.0 + 5e-5};
  const auto restart_at = [&](const ValueStall& rule) {
    TrustRegionOptions o;
    o.restart_center = "new_points";
    TrustRegion tr(2, o);
    tr.set_value_stall(rule);
    Dataset data = Dataset::empty(2);
    observe(tr, data, (Vec(2) << 0.9, 0.9).finished(), 0.0);  // the design's worst point: range ≈ 3
    for (std::size_t i = 0; i < costs.size(); ++i) {
      observe(tr, data, (Vec(2) << 0.4 + 0.01 * static_cast<double>(i % 2), 0.6 - 0.01 * static_cast<double>(i))
                            .finished(),
              costs[i]);
      if (tr.restarts() > 0) return static_cast<int>(i);
    }
    return -1;
  };
  ValueStall rule;
  rule.fraction = 1e-4;
  rule.scale = ValueStall::Scale::Range;  // tolerance 3e-4: every trial after the first is a value stall
  CHECK(restart_at(rule) == 2);
  rule.strict = true;  // trials 2 and 4 improve (by 1e-5 and 1e-5): they reset the count; 5 and 6 end it
  CHECK(restart_at(rule) == 6);
  CHECK(restart_at(ValueStall{}) == -1);  // off: the points are never next to the incumbent
}

namespace {
// Sets the region's forced failures / halvings through its state, as bo's failure_model.feasible_region does.
void force(TrustRegion& tr, int failures, int halvings) {
  StateMap m = StateMap::parse(tr.save_state(), "test");
  if (failures > 0) m.put_int("forced_failures", failures);
  if (halvings > 0) m.put_int("forced_halvings", halvings);
  tr.restore_state(m.text());
}
}  // namespace

TEST_CASE("trust_region: forced failures (session fail14) count as trials without improvement, even an improving one") {
  TrustRegion tr(2, {});  // τ_fail = 4, τ_succ = 3
  Dataset data = Dataset::empty(2);
  observe(tr, data, (Vec(2) << 0.5, 0.5).finished(), 10.0);  // reference
  CHECK(tr.save_state().find("forced") == std::string::npos);  // absent when 0: states without the option unchanged
  // Forced failures before a reference update are dropped with it: not applicable here (reference done).
  // An improving step that was limited: a failure, not a success; the box still centres on the new best.
  force(tr, 1, 0);
  CHECK(tr.forced_failures() == 1);
  CHECK(StateMap::parse(tr.save_state(), "test").integer("forced_failures") == 1);
  observe(tr, data, (Vec(2) << 0.6, 0.5).finished(), 5.0);
  CHECK(tr.successes() == 0);
  CHECK(tr.failures() == 1);
  CHECK(tr.forced_failures() == 0);
  CHECK(tr.center().isApprox((Vec(2) << 0.6, 0.5).finished()));
  // The next plain improvement is measured against the new best (5): 4.0 is a success.
  observe(tr, data, (Vec(2) << 0.62, 0.5).finished(), 4.0);
  CHECK(tr.successes() == 1);
  CHECK(tr.failures() == 0);
  // Failed trials add no point: an update without new data counts the forced failures (3 here + 1 plain = τ_fail).
  force(tr, 3, 0);
  Rng rng(0);
  tr.update(nullptr, data, rng);
  CHECK(tr.failures() == 3);
  CHECK(tr.successes() == 0);
  CHECK(tr.stalls() == 0);  // no point next to the incumbent was added: no stall
  CHECK(tr.length() == doctest::Approx(0.8));
  observe(tr, data, (Vec(2) << 0.1, 0.1).finished(), 50.0);
  CHECK(tr.length() == doctest::Approx(0.4));
  CHECK(tr.failures() == 0);
  // Nine forced failures at once: two halvings, one failure left over.
  force(tr, 9, 0);
  tr.update(nullptr, data, rng);
  CHECK(tr.length() == doctest::Approx(0.1));
  CHECK(tr.failures() == 1);
  // Without forced failures an update without new data still changes nothing.
  const std::string before = tr.save_state();
  tr.update(nullptr, data, rng);
  CHECK(tr.save_state() == before);
}

TEST_CASE("trust_region: forced halvings halve L each; a collapse restarts afresh; a reference update drops them") {
  TrustRegion tr(2, {});
  Dataset data = Dataset::empty(2);
  observe(tr, data, (Vec(2) << 0.5, 0.5).finished(), 10.0);
  force(tr, 0, 2);
  Rng rng(0);
  tr.update(nullptr, data, rng);
  CHECK(tr.length() == doctest::Approx(0.2));
  CHECK(tr.failures() == 0);  // halvings are not counted failures
  // 0.2 / 2^5 = 0.00625 < 0.5^7: a restart (a fresh start with the default restart_center: new_points).
  force(tr, 0, 5);
  tr.update(nullptr, data, rng);
  CHECK(tr.restarts() == 1);
  CHECK(tr.fresh_starts() == 1);
  CHECK(tr.length() == doctest::Approx(0.8));
  // The fresh start's first point sets its reference: forced failures pending then are dropped.
  force(tr, 2, 1);
  observe(tr, data, (Vec(2) << 0.2, 0.2).finished(), 30.0);
  CHECK(tr.forced_failures() == 0);
  CHECK(tr.forced_halvings() == 0);
  CHECK(tr.failures() == 0);
  CHECK(tr.length() == doctest::Approx(0.8));
}

TEST_CASE("trust_region: an anchor (session fail15) is a point of the fresh attempt: its centre while the best") {
  // bo's follow_probe restarts the region and anchors the new attempt at a probe observed before the restart.
  TrustRegionOptions o;
  o.restart_center = "new_points";
  o.failure_tolerance = 1;
  TrustRegion tr(2, o);
  Dataset data = Dataset::empty(2);
  observe(tr, data, (Vec(2) << 0.9, 0.95).finished(), 1.0);  // the incumbent of all the data
  observe(tr, data, (Vec(2) << 0.1, 0.2).finished(), 2.0);   // the probe (data index 1)
  for (int k = 0; k < 7 && tr.restarts() == 0; ++k) observe(tr, data, (Vec(2) << 0.5, 0.1 * k).finished(), 5.0);
  REQUIRE(tr.restarts() == 1);
  CHECK(tr.anchor() == -1);
  StateMap m = StateMap::parse(tr.save_state(), "test");
  CHECK_FALSE(m.has("anchor"));  // absent without one: older states unchanged
  m.put_int("anchor", 1);
  tr.restore_state(m.text());
  CHECK(tr.anchor() == 1);
  // No point since the restart: the box is around the anchor, not the incumbent (0.9, 0.95).
  Rng rng(0);
  tr.update(nullptr, data, rng);
  CHECK(tr.center() == (Vec(2) << 0.1, 0.2).finished());
  // A worse new point: the anchor stays the centre, and the reference is the anchor's cost (2.0), so 1.9 later is a
  // success although the incumbent of all the data is 1.0.
  observe(tr, data, (Vec(2) << 0.15, 0.2).finished(), 3.0);
  CHECK(tr.center() == (Vec(2) << 0.1, 0.2).finished());
  CHECK(tr.successes() == 0);
  observe(tr, data, (Vec(2) << 0.12, 0.22).finished(), 1.9);
  CHECK(tr.successes() == 1);
  CHECK(tr.center() == (Vec(2) << 0.12, 0.22).finished());
  // The state carries the anchor; a restored region continues identically.
  TrustRegion copy(2, o);
  copy.restore_state(tr.save_state());
  CHECK(copy.anchor() == 1);
  // The next restart drops it.
  for (int k = 0; k < 7 && tr.restarts() == 1; ++k) observe(tr, data, (Vec(2) << 0.7, 0.1 * k).finished(), 5.0);
  REQUIRE(tr.restarts() == 2);
  CHECK(tr.anchor() == -1);
  CHECK_FALSE(StateMap::parse(tr.save_state(), "test").has("anchor"));
  StateMap bad = StateMap::parse(tr.save_state(), "test");
  bad.put_int("anchor", -3);
  CHECK_THROWS_AS(copy.restore_state(bad.text()), InputError);
}

TEST_CASE("trust_region: a restored state has the very box of the saved region, at every step") {
  // Session 25 (red team): before its first update the region is the whole unit cube, but a restored state rebuilt
  // the box from the centre (0.5) and L (0.8), so bo's random points of a resumed run came from [0.1, 0.9]^d and the
  // run diverged from the uninterrupted one. The same after return_to_incumbent (L changed, the box not yet).
  TrustRegionOptions o;
  o.restart_center = "new_points";
  o.failure_tolerance = 1;
  o.length_min = 0.05;
  TrustRegion tr(2, o);
  Dataset data = Dataset::empty(2);
  int checked = 0;
  auto same_after_restore = [&](const char* when) {
    CAPTURE(when);
    TrustRegion copy(2, o);
    copy.restore_state(tr.save_state());
    CHECK(copy.bounds().lower == tr.bounds().lower);
    CHECK(copy.bounds().upper == tr.bounds().upper);
    CHECK(copy.save_state() == tr.save_state());
    ++checked;
  };
  same_after_restore("before any data");
  CHECK(tr.bounds().lower == Vec::Zero(2));
  observe(tr, data, (Vec(2) << 0.9, 0.95).finished(), 1.0);
  same_after_restore("after the first update");
  for (int k = 0; k < 5; ++k) {
    observe(tr, data, (Vec(2) << 0.1 * k, 0.1).finished(), 5.0);
    same_after_restore("failures, a fresh start");
  }
  observe(tr, data, (Vec(2) << 0.3, 0.3).finished(), 4.0);
  tr.return_to_incumbent();
  same_after_restore("right after return_to_incumbent");
  observe(tr, data, (Vec(2) << 0.35, 0.3).finished(), 4.5);
  same_after_restore("after the next update");
  CHECK(checked == 9);
  // A state written before the box was stored (no box keys), saved before the first update: the unit cube.
  TrustRegion fresh(2, o);
  TrustRegion old(2, o);
  std::string text = fresh.save_state();
  REQUIRE(text.find("box_lower") != std::string::npos);
  std::string without;  // the state's lines but the box's
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);)
    if (line.rfind("box_", 0) != 0) without += line + "\n";
  old.restore_state(without);
  CHECK(old.bounds().lower == fresh.bounds().lower);
  CHECK(old.bounds().upper == fresh.bounds().upper);
}
