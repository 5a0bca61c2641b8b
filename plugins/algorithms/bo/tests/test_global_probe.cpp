// failure_model.global_probe (bo_global_probe.cpp, session 36): on Hartmann-3 with bench_failures' ball across the
// global valley, the fresh start's first point goes behind the ball, where the model of every trial sees the costs
// fall, and the attempt continues from it; a run without failures is unchanged; the run is the same with 1 and 2
// threads and continues from a saved state exactly.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bo_on_bowl.hpp"
#include "failing_hartmann3.hpp"
#include "study_helpers.hpp"
#include "varbo/algorithm.hpp"
#include "varbo/log.hpp"
#include "varbo/registry.hpp"
#include "varbo/state.hpp"
#include "varbo/task.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {

const std::string& kBall = test::kHartmann3Ball;
// The scenario is session 36's, with its value stalls and refinement (test::kSession39Stalls) and without the probes
// during an attempt (test::kNoAttemptProbes, session 41); global_probe is on by default since session 36.
const std::string kSession36 = test::kSession39Stalls + ", " + test::kNoAttemptProbes;
const std::string kProbe = "{type: bo, failure_model: {" + kSession36 + "}}";
const std::string kPlain = "{type: bo, failure_model: {global_probe: false, " + kSession36 + "}}";

std::vector<std::vector<std::string>> run(const std::string& algorithm, bool failing, int threads) {
  return test::run_hartmann3(algorithm == kProbe ? "global_probe_on" : "global_probe_off", algorithm, failing, threads);
}

}  // namespace

TEST_CASE("global_probe: the fresh start's first point goes behind the failure region, and the attempt follows it") {
  // Seed 1 (budget 50), without the probe: the first attempt ends at x1 = 0.76 on the ball's far side from the global
  // minimizer (0.115, 0.556, 0.853; cost −3.8628), held at the ball (best −3.6575, regret 0.19); the fresh start's
  // design never reaches the small feasible part of the global basin (docs/failures.md, session 36).
  set_log_level(LogLevel::Error);
  const auto plain = run(kPlain, true, 1), probe = run(kProbe, true, 1), two = run(kProbe, true, 2);
  REQUIRE(plain.size() == 51);
  REQUIRE(probe.size() == 51);
  REQUIRE(two.size() == 51);
  const auto& h = probe[0];
  const int phase = test::column_of(h, "phase"), x1 = test::column_of(h, "x1"), ok = test::column_of(h, "ok"),
            cost = test::column_of(h, "cost");
  REQUIRE(phase >= 0);
  std::size_t at = 0;
  for (std::size_t r = 1; r < probe.size(); ++r)
    if (probe[r][static_cast<std::size_t>(phase)] == "probe") {
      CHECK(at == 0);  // one fresh start, one probe
      at = r;
    }
  REQUIRE(at > 0);
  // The trials before it are the plain run's (the probe replaces a fresh design point, nothing earlier).
  for (std::size_t r = 1; r < at; ++r)
    for (int d = 0; d < 3; ++d)
      CHECK(probe[r][static_cast<std::size_t>(x1 + d)] == plain[r][static_cast<std::size_t>(x1 + d)]);
  CHECK(plain[at][static_cast<std::size_t>(phase)] == "restart");
  // Behind the ball (x1 below its extent, 0.169, at x2 = 0.556, x3 = 0.853), a success better than every trial
  // before it.
  const auto value = [&](std::size_t r, int c) { return std::stod(probe[r][static_cast<std::size_t>(c)]); };
  CHECK(value(at, x1) < 0.169);
  REQUIRE(probe[at][static_cast<std::size_t>(ok)] == "1");
  for (std::size_t r = 1; r < at; ++r)
    if (probe[r][static_cast<std::size_t>(ok)] == "1") CHECK(value(at, cost) < value(r, cost));
  // Followed at once: the next trial is no design point of the fresh start.
  CHECK(probe[at + 1][static_cast<std::size_t>(phase)] != "restart");
  // The best cost found: the global basin's (−3.8628 at the minimizer) against the plain run's −3.66.
  double best_plain = 0, best_probe = 0;
  for (std::size_t r = 1; r < probe.size(); ++r) {
    if (plain[r][static_cast<std::size_t>(ok)] == "1") best_plain = std::min(best_plain, std::stod(plain[r][static_cast<std::size_t>(cost)]));
    if (probe[r][static_cast<std::size_t>(ok)] == "1") best_probe = std::min(best_probe, value(r, cost));
  }
  CHECK(best_plain > -3.7);
  CHECK(best_probe < -3.86);
  // A seed fixes the run whatever the thread count.
  for (std::size_t r = 1; r < probe.size(); ++r)
    for (int d = 0; d < 3; ++d) CHECK(probe[r][static_cast<std::size_t>(x1 + d)] == two[r][static_cast<std::size_t>(x1 + d)]);
}

TEST_CASE("global_probe: a run in which no trial fails is unchanged") {
  set_log_level(LogLevel::Error);
  const auto plain = run(kPlain, false, 1), probe = run(kProbe, false, 1);
  REQUIRE(plain.size() == 51);
  REQUIRE(probe.size() == plain.size());
  const int x1 = test::column_of(plain[0], "x1"), phase = test::column_of(plain[0], "phase");
  int restarts = 0;
  for (std::size_t r = 1; r < plain.size(); ++r) {
    restarts += plain[r][static_cast<std::size_t>(phase)] == "restart";
    CHECK(probe[r][static_cast<std::size_t>(phase)] == plain[r][static_cast<std::size_t>(phase)]);
    for (int d = 0; d < 3; ++d)
      CHECK(probe[r][static_cast<std::size_t>(x1 + d)] == plain[r][static_cast<std::size_t>(x1 + d)]);
  }
  CHECK(restarts > 0);  // the run has fresh starts, where a probe would go
}

TEST_CASE("global_probe: a run continues from a state saved with the probe exactly as without saving") {
  // Saved twice: with the probe asked and its result not yet told (a study saves its state with each suggestion),
  // and after its result.
  set_log_level(LogLevel::Error);
  const BuildContext ctx = test::bo_context(3, 50, 1);
  const test::TaskObserver observe("{type: hartmann3, failure_region: " + kBall + "}", ctx);
  auto a = test::registry().create<Algorithm>(kProbe, ctx);
  std::vector<Observation> told;
  struct Saved {
    std::string state;
    std::vector<Observation> told;
    bool asked = false;  ///< saved with the probe asked, its result not told
  };
  std::vector<Saved> saved;
  std::vector<Suggestion> later;  // the original run's suggestions from the probe on
  for (Index k = 0; k < 50 && later.size() < 4; ++k) {
    const Suggestion s = a->ask(1).front();
    if (!saved.empty()) later.push_back(s);
    if (s.phase == "probe") {
      later.push_back(s);
      saved.push_back({*dynamic_cast<AlgorithmState&>(*a).save_state(), told, true});
      CHECK(StateMap::parse(saved.back().state, "bo state").integer("probe_trial") == k);
    }
    const Observation o = observe(s.x);
    a->tell({o});
    told.push_back(o);
    if (s.phase == "probe") saved.push_back({*dynamic_cast<AlgorithmState&>(*a).save_state(), told, false});
  }
  REQUIRE(saved.size() == 2);
  REQUIRE(later.size() == 4);
  for (const Saved& from : saved) {
    CAPTURE(from.asked);
    auto b = test::registry().create<Algorithm>(kProbe, ctx);
    dynamic_cast<AlgorithmState&>(*b).restore_state(from.state, from.told);
    if (from.asked) b->tell({observe(later[0].x)});  // the outstanding probe's result
    for (std::size_t i = 1; i < later.size(); ++i) {
      const Suggestion s = b->ask(1).front();
      CHECK((s.x - later[i].x).norm() == 0.0);
      CHECK(s.phase == later[i].phase);
      b->tell({observe(s.x)});
    }
  }
  // A state whose probe trial was never asked is refused.
  StateMap bad = StateMap::parse(saved.back().state, "bo state");
  bad.put_int("probe_trial", 1000);
  auto c = test::registry().create<Algorithm>(kProbe, ctx);
  CHECK_THROWS_AS(dynamic_cast<AlgorithmState&>(*c).restore_state(bad.text(), saved.back().told), InputError);
}
