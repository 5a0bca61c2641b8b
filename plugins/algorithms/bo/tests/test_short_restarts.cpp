// failure_model.short_restarts (session 38): once a trial has failed, a fresh start's design has d + 1 points
// instead of restart_points (2(d + 1) by default). Hartmann-6 with held-out region 0 of session 37 (a box cutting x2
// between the global minimiser and the rest of the box), seed 1: the run restarts after failures in its design.
#include <optional>
#include <string>
#include <vector>

#include "bo_on_bowl.hpp"
#include "failing_hartmann6.hpp"
#include "study_helpers.hpp"
#include "varbo/algorithm.hpp"
#include "varbo/log.hpp"
#include "varbo/registry.hpp"
#include "varbo/state.hpp"
#include "varbo/task.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {

using test::Rows;

// The lengths of the blocks of consecutive rows of phase "restart" (a fresh start's design).
std::vector<int> restart_blocks(const Rows& rows) {
  const auto phase = static_cast<std::size_t>(test::column_of(rows[0], "phase"));
  std::vector<int> blocks;
  int current = 0;
  for (std::size_t r = 1; r <= rows.size(); ++r) {
    if (r < rows.size() && rows[r][phase] == "restart") {
      ++current;
    } else if (current > 0) {
      blocks.push_back(current);
      current = 0;
    }
  }
  return blocks;
}

}  // namespace

TEST_CASE("short_restarts: after failures a fresh start's design has d + 1 points; without failures nothing changes") {
  set_log_level(LogLevel::Error);
  const Rows with = test::run_hartmann6("short_restarts", true, ""), two = test::run_hartmann6("short_restarts", true, "", 2),
             off = test::run_hartmann6("short_restarts_off", true, "{short_restarts: false}");
  REQUIRE(with.size() == 101);
  REQUIRE(off.size() == 101);
  const std::vector<int> short_blocks = restart_blocks(with), long_blocks = restart_blocks(off);
  REQUIRE(!short_blocks.empty());
  REQUIRE(!long_blocks.empty());
  // The design of every fresh start: d + 1 = 7 points (fewer only where a global probe ended it, or the budget).
  for (const int n : short_blocks) CHECK(n <= 7);
  CHECK(short_blocks.front() == 7);
  // Without the rule, restart_points = initial_points = 2(d + 1) = 14.
  CHECK(long_blocks.front() == 14);
  // The design's trials are the same up to the first fresh start (the rule changes nothing before it).
  const auto phase = static_cast<std::size_t>(test::column_of(with[0], "phase"));
  const auto x1 = static_cast<std::size_t>(test::column_of(with[0], "x1"));
  for (std::size_t r = 1; r < with.size() && with[r][phase] != "restart"; ++r)
    for (std::size_t d = 0; d < 6; ++d) CHECK(with[r][x1 + d] == off[r][x1 + d]);
  // A seed fixes the run whatever the thread count.
  CHECK(test::same_thetas(with, two));
  // A run without failures is unchanged, trial for trial.
  CHECK(test::same_thetas(test::run_hartmann6("short_restarts", false, ""),
                         test::run_hartmann6("short_restarts_off", false, "{short_restarts: false}")));
}

TEST_CASE("short_restarts: a run continues from a state saved inside a shortened fresh design exactly as without saving") {
  set_log_level(LogLevel::Error);
  test::FailingHartmann6Bo run;
  std::optional<test::FailingHartmann6Bo::Saved> saved;
  std::vector<Suggestion> later;
  int in_design = 0;
  for (Index k = 0; k < 100 && later.size() < 10; ++k) {
    const Suggestion s = run.step();
    if (saved) later.push_back(s);
    in_design = s.phase == "restart" ? in_design + 1 : 0;
    if (in_design == 3 && !saved) saved = run.save();  // three points into the first fresh design
  }
  REQUIRE(saved);
  REQUIRE(later.size() == 10);
  // The design ends after its 7th point: 4 more design points, then the model's trials.
  for (int i = 0; i < 4; ++i) CHECK(later[static_cast<std::size_t>(i)].phase == "restart");
  CHECK(later[4].phase != "restart");
  run.check_continues_as(*saved, later);
}
