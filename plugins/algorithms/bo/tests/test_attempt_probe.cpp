// failure_model.probe_every (bo_global_probe.cpp, session 41): on Hartmann-3 with bench_failures' ball across the
// global valley (seed 1, budget 50), the first attempt creeps along the ball's face on the blocked side for its whole
// budget without the rule; with it, a probe during that attempt goes behind the ball, where the model of every
// successful trial is confident the costs fall, and the run ends in the global basin. A run without failures is
// unchanged; the run is the same with 1 and 2 threads and continues from a saved state exactly.
#include <algorithm>
#include <string>
#include <vector>

#include "bo_on_bowl.hpp"
#include "failing_hartmann3.hpp"
#include "varbo/algorithm.hpp"
#include "varbo/errors.hpp"
#include "varbo/log.hpp"
#include "varbo/registry.hpp"
#include "varbo/state.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {

const std::string kDefault = "{type: bo}";  // probe_every: -1 (d + 1) by default since session 41
const std::string kOff = "{type: bo, failure_model: {probe_every: 0}}";
// Seed 1's scenario with the trust region of session 41 (with session 43's cap the first probe comes later).
const std::string kPinned = "{type: bo, failure_model: {" + test::kNoSideCap + "}}";
const std::string kPinnedOff = "{type: bo, failure_model: {probe_every: 0, " + test::kNoSideCap + "}}";

using Rows = std::vector<std::vector<std::string>>;

Rows run(const std::string& algorithm, bool failing, int threads) {
  const std::string tag = algorithm == kOff ? "attempt_probe_off" : algorithm == kDefault ? "attempt_probe_on"
                          : algorithm == kPinnedOff                                ? "attempt_probe_pinned_off"
                                                                                   : "attempt_probe_pinned";
  return test::run_hartmann3(tag, algorithm, failing, threads);
}

std::size_t col(const Rows& rows, const char* name) {
  const int c = test::column_of(rows[0], name);
  REQUIRE(c >= 0);
  return static_cast<std::size_t>(c);
}

/// The lowest successful cost of rows [1, end).
double best_cost(const Rows& rows, std::size_t end) {
  double best = 0;
  for (std::size_t r = 1; r < end; ++r)
    if (rows[r][col(rows, "ok")] == "1") best = std::min(best, std::stod(rows[r][col(rows, "cost")]));
  return best;
}

bool same_thetas(const Rows& a, const Rows& b, std::size_t end) {
  const std::size_t x1 = col(a, "x1");
  for (std::size_t r = 1; r < end; ++r)
    for (std::size_t d = 0; d < 3; ++d)
      if (a[r][x1 + d] != b[r][x1 + d]) return false;
  return true;
}

}  // namespace

TEST_CASE("probe_every: a probe during the first attempt goes behind the failure region and the run ends there") {
  set_log_level(LogLevel::Error);
  const Rows off = run(kPinnedOff, true, 1), on = run(kPinned, true, 1), two = run(kPinned, true, 2);
  REQUIRE(off.size() == 51);
  REQUIRE(on.size() == 51);
  REQUIRE(two.size() == 51);
  const std::size_t phase = col(on, "phase"), x1 = col(on, "x1"), ok = col(on, "ok"), cost = col(on, "cost"),
                    regret = col(on, "regret_recommended");
  // Without the rule the run is stuck on the ball's blocked side: the global minimizer is (0.115, 0.556, 0.853),
  // cost −3.8628; the best trial is −3.66 at x1 ≈ 0.76 and the recommendation's regret ≈ 0.19.
  CHECK(best_cost(off, off.size()) > -3.7);
  CHECK(std::stod(off.back()[regret]) > 0.1);
  // The first probe comes during the first attempt: no fresh start's design trial before it.
  std::size_t at = 0;
  for (std::size_t r = 1; r < on.size() && at == 0; ++r) {
    REQUIRE(on[r][phase] != "restart");
    if (on[r][phase] == "probe") at = r;
  }
  REQUIRE(at > 0);
  // The trials before it are the run's without the rule (nothing acts earlier).
  CHECK(same_thetas(on, off, at));
  // Behind the ball (x1 below the ball's extent, 0.169, at x2 = 0.556, x3 = 0.853), a success better than every
  // trial before it, close to the global minimum.
  CHECK(std::stod(on[at][x1]) < 0.169);
  REQUIRE(on[at][ok] == "1");
  CHECK(std::stod(on[at][cost]) < best_cost(on, at));
  CHECK(std::stod(on[at][cost]) < -3.8);
  // The run ends in the global basin (regret of the recommended θ against the feasible optimum).
  CHECK(std::stod(on.back()[regret]) < 1e-3);
  // The same trials with 2 threads.
  CHECK(same_thetas(on, two, on.size()));
}

TEST_CASE("probe_every: a run in which no trial fails is unchanged") {
  set_log_level(LogLevel::Error);
  const Rows off = run(kOff, false, 1), on = run(kDefault, false, 1);
  REQUIRE(off.size() == 51);
  REQUIRE(on.size() == off.size());
  const std::size_t phase = col(on, "phase");
  for (std::size_t r = 1; r < on.size(); ++r) CHECK(on[r][phase] == off[r][phase]);
  CHECK(same_thetas(on, off, on.size()));
}

TEST_CASE("probe_every: a run continues from a state saved at the probe exactly as without saving") {
  // Saved with the probe asked and its result not yet told (a study saves its state with each suggestion), and
  // after its result; the rule keeps no state of its own (its trials are counted from the attempt's start).
  set_log_level(LogLevel::Error);
  const BuildContext ctx = test::bo_context(3, 50, 1);
  const test::TaskObserver observe("{type: hartmann3, failure_region: " + test::kHartmann3Ball + "}", ctx);
  auto a = test::registry().create<Algorithm>(kDefault, ctx);
  std::vector<Observation> told;
  std::string asked_state, told_state;
  std::vector<Observation> asked_told;
  std::vector<Suggestion> later;  // the original run's suggestions from the probe on
  for (Index k = 0; k < 50 && later.size() < 5; ++k) {
    const Suggestion s = a->ask(1).front();
    const bool first_probe = s.phase == "probe" && asked_state.empty();
    if (!asked_state.empty()) later.push_back(s);
    if (first_probe) {
      later.push_back(s);
      asked_state = *dynamic_cast<AlgorithmState&>(*a).save_state();
      asked_told = told;
    }
    const Observation o = observe(s.x);
    a->tell({o});
    told.push_back(o);
    if (first_probe) told_state = *dynamic_cast<AlgorithmState&>(*a).save_state();
  }
  REQUIRE(later.size() == 5);
  const std::vector<Suggestion> after_probe(later.begin() + 1, later.end());
  // Saved after the probe's result.
  std::vector<Observation> with_probe = asked_told;
  with_probe.push_back(observe(later[0].x));
  test::check_continues_as(kDefault, ctx, told_state, with_probe, after_probe, observe);
  // Saved with the probe asked, not told: the outstanding probe's result first, then the rest.
  auto b = test::registry().create<Algorithm>(kDefault, ctx);
  dynamic_cast<AlgorithmState&>(*b).restore_state(asked_state, asked_told);
  b->tell({observe(later[0].x)});
  for (const Suggestion& e : after_probe) {
    const Suggestion s = b->ask(1).front();
    CHECK((s.x - e.x).norm() == 0.0);
    CHECK(s.phase == e.phase);
    b->tell({observe(s.x)});
  }
}

TEST_CASE("probe_every: a value below -1 is refused, naming the key") {
  const BuildContext ctx = test::bo_context(3, 50, 1);
  try {
    (void)test::registry().create<Algorithm>("{type: bo, failure_model: {probe_every: -2}}", ctx);
    FAIL("probe_every: -2 was accepted");
  } catch (const ConfigError& e) {
    CHECK(std::string(e.what()).find("failure_model.probe_every") != std::string::npos);
    CHECK(std::string(e.what()).find("[-1, inf)") != std::string::npos);
  }
}
