// failure_model.refine_last (session 40): once a trial has failed, bo's final refinement takes at least 2(d + 1)
// trials instead of d + 1. Failures cut attempts short, and the last attempt of a failing run often reaches its basin
// late: with d + 1 trials it ends unpolished (docs/failures.md, "Session 40").
#include <cstddef>
#include <string>
#include <vector>

#include "failing_hartmann6.hpp"
#include "varbo/algorithm.hpp"
#include "varbo/log.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {

// How many rows at the end of trials.csv have phase "refine" (the final refinement, refine_early included).
int refinement_length(const test::Rows& rows) {
  const auto phase = static_cast<std::size_t>(test::column_of(rows[0], "phase"));
  int n = 0;
  for (std::size_t r = rows.size() - 1; r >= 1 && rows[r][phase] == "refine"; --r) ++n;
  return n;
}

int failures(const test::Rows& rows) {
  const auto ok = static_cast<std::size_t>(test::column_of(rows[0], "ok"));
  int n = 0;
  for (std::size_t r = 1; r < rows.size(); ++r) n += rows[r][ok] == "0";
  return n;
}

}  // namespace

TEST_CASE("failure_model.refine_last: after failures the final refinement is at least 2(d + 1) trials; without failures "
          "nothing changes") {
  set_log_level(LogLevel::Error);
  const test::Rows with = test::run_hartmann6("failure_refine", true, ""),
                   two = test::run_hartmann6("failure_refine", true, "", 2),
                   off = test::run_hartmann6("failure_refine_off", true, "{refine_last: 0}");
  REQUIRE(with.size() == 101);
  REQUIRE(failures(with) > 0);
  // d = 6: at least 14 trials; with the rule off, bo's refine_last (d + 1 = 7) unless refine_early began it sooner.
  CHECK(refinement_length(with) >= 14);
  CHECK(refinement_length(off) >= 7);
  CHECK(refinement_length(off) < 14);
  // A seed fixes the run whatever the thread count.
  CHECK(test::same_thetas(with, two));
  // A run without failures is unchanged, trial for trial, whatever failure_model.refine_last says.
  const test::Rows free = test::run_hartmann6("failure_refine", false, "");
  REQUIRE(failures(free) == 0);
  CHECK(test::same_thetas(free, test::run_hartmann6("failure_refine_20", false, "{refine_last: 20}")));
}

TEST_CASE("failure_model.refine_last: a run continues from a state saved inside the lengthened refinement exactly as "
          "without saving") {
  set_log_level(LogLevel::Error);
  test::FailingHartmann6Bo run;
  test::FailingHartmann6Bo::Saved saved;
  std::vector<Suggestion> later;
  for (Index k = 0; k < 100; ++k) {
    if (k == 90) saved = run.save();  // 10 trials left: inside 2(d + 1) = 14, before d + 1 = 7
    const Suggestion s = run.step();
    if (k >= 90) later.push_back(s);
  }
  REQUIRE(later.size() == 10);
  for (const Suggestion& s : later) CHECK(s.phase == "refine");
  run.check_continues_as(saved, later);
}
