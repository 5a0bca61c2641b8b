// failure_model.failure_run (bo_restart_rules.cpp, session 37): Hartmann-6 with a ball of 30 % of the box whose face
// passes through the local minimum (a region drawn at random for a held-out check, not one tuned on), seed 70: the
// attempt at the local minimum proposed one failing θ after another beside its incumbent until stop_after_failures
// (10 in a row) ended the run. With the rule (default 6), an attempt whose last 6 model-based trials failed ends.
// The scenario is session 37's, with its value stalls and refinement (test::kSession39Stalls) and its trust region
// (test::kNoSideCap).
#include <algorithm>
#include <string>
#include <vector>

#include "bo_on_bowl.hpp"
#include "study_helpers.hpp"
#include "varbo/algorithm.hpp"
#include "varbo/errors.hpp"
#include "varbo/log.hpp"
#include "varbo/registry.hpp"
#include "varbo/state.hpp"
#include "varbo/task.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {

const std::string kBall = "{shape: ball, center: [0.498, 0.6, 0.539, 0.339, 0.553, 0.218], radius: 0.67}";

constexpr int kDefault = 6;  // failure_model.failure_run's default

// failure_run < 0: the default (the key not given).
std::string yaml(int failure_run, int stop_after) {
  return "task: {type: hartmann6, failure_region: " + kBall + "}\nbudget: 100\nseed: 70\nstop_after_failures: " +
         std::to_string(stop_after) + "\nalgorithm: " +
         "{type: bo, failure_model: {" + test::kSession39Stalls + ", " + test::kNoSideCap +
         (failure_run < 0 ? std::string() : ", failure_run: " + std::to_string(failure_run)) + "}}" +
         "\n";
}

std::vector<std::vector<std::string>> run(int failure_run, int stop_after, int threads = 1) {
  RunOverrides ov;
  ov.output = test::temp_folder("failure_run_" + std::to_string(failure_run + 1) + "_" + std::to_string(stop_after) + "_" +
                                std::to_string(threads));
  ov.threads = threads;
  test::run_yaml(yaml(failure_run, stop_after), test::registry(), ov);
  return test::read_rows(*ov.output + "/trials.csv");
}

// The longest run of failed trials in a row among the rows whose phase is one of `phases` (rows of other phases
// end a run).
int longest_failure_run(const std::vector<std::vector<std::string>>& rows, const std::vector<std::string>& phases) {
  const auto phase = static_cast<std::size_t>(test::column_of(rows[0], "phase"));
  const auto ok = static_cast<std::size_t>(test::column_of(rows[0], "ok"));
  int longest = 0, current = 0;
  for (std::size_t r = 1; r < rows.size(); ++r) {
    const bool counted = std::find(phases.begin(), phases.end(), rows[r][phase]) != phases.end();
    current = counted && rows[r][ok] == "0" ? current + 1 : 0;
    longest = std::max(longest, current);
  }
  return longest;
}

}  // namespace

TEST_CASE("failure_run: an attempt failing trial after trial beside its incumbent ends; the run does not stop") {
  set_log_level(LogLevel::Error);
  // Without the rule the run stops: 10 failed trials in a row (stop_after_failures' default).
  CHECK_THROWS_AS(run(0, 10), InputError);
  const auto without = run(0, 0);  // the same run, not stopped
  REQUIRE(without.size() == 101);
  CHECK(longest_failure_run(without, {"ei"}) >= 10);

  const auto with = run(-1, 10), two = run(-1, 10, 2);
  REQUIRE(with.size() == 101);  // the whole budget
  CHECK(longest_failure_run(with, {"ei"}) <= kDefault);
  // The trials up to the end of the first run of kDefault failures are the run's without the rule.
  const auto phase = static_cast<std::size_t>(test::column_of(with[0], "phase"));
  const auto ok = static_cast<std::size_t>(test::column_of(with[0], "ok"));
  const auto x1 = static_cast<std::size_t>(test::column_of(with[0], "x1"));
  std::size_t ended = 0;
  for (std::size_t r = kDefault; r < with.size() && ended == 0; ++r) {
    bool all_failed = true;
    for (std::size_t j = r + 1 - kDefault; j <= r; ++j) all_failed = all_failed && with[j][ok] == "0" && with[j][phase] == "ei";
    if (all_failed) ended = r;
  }
  REQUIRE(ended > 0);
  for (std::size_t r = 1; r <= ended; ++r)
    for (std::size_t d = 0; d < 6; ++d) CHECK(with[r][x1 + d] == without[r][x1 + d]);
  // Then a fresh start.
  CHECK(with[ended + 1][phase] != "ei");
  CHECK(without[ended + 1][phase] == "ei");
  // Fewer failures in all (each is a fall on a robot).
  const auto failures = [&](const std::vector<std::vector<std::string>>& rows) {
    return std::count_if(rows.begin() + 1, rows.end(), [&](const auto& row) { return row[ok] == "0"; });
  };
  CHECK(failures(with) < failures(without));
  // A seed fixes the run whatever the thread count.
  for (std::size_t r = 1; r < with.size(); ++r)
    for (std::size_t d = 0; d < 6; ++d) CHECK(with[r][x1 + d] == two[r][x1 + d]);
}

TEST_CASE("failure_run: a run continues from a state saved after the attempt ended exactly as without saving") {
  set_log_level(LogLevel::Error);
  const BuildContext ctx = test::bo_context(6, 100, 70);
  const test::TaskObserver observe("{type: hartmann6, failure_region: " + kBall + "}", ctx);
  // failure_run: kDefault; the region as in session 37 (with session 43's cap the attempt ends otherwise).
  const std::string algorithm = "{type: bo, failure_model: {" + test::kNoSideCap + "}}";
  auto a = test::registry().create<Algorithm>(algorithm, ctx);
  std::vector<Observation> told;
  std::string state;
  std::vector<Observation> told_at_save;
  std::vector<Suggestion> later;
  int in_a_row = 0;
  for (Index k = 0; k < 100 && later.size() < 6; ++k) {
    const Suggestion s = a->ask(1).front();
    if (!state.empty()) later.push_back(s);
    const Observation o = observe(s.x);
    a->tell({o});
    told.push_back(o);
    in_a_row = s.phase == "ei" && !o.ok ? in_a_row + 1 : 0;
    if (in_a_row == kDefault && state.empty()) {  // saved with the attempt's last failure in a row told
      state = *dynamic_cast<AlgorithmState&>(*a).save_state();
      told_at_save = told;
    }
  }
  REQUIRE(!state.empty());
  REQUIRE(later.size() == 6);
  CHECK(later[0].phase != "ei");  // the fresh start
  test::check_continues_as(algorithm, ctx, state, told_at_save, later, observe);
}
