// failure_model.refine_known (session 44; docs/failures.md, item 15): once a trial has failed, a final refinement
// trial whose best point is a θ already measured, on a cost the model treats as deterministic, takes the attempts'
// acquisition's (EI's) best new point at the same level of P(success) instead. Hartmann-6 with the benchmark's slab
// x6 > 0.7 (bench_failures), seed 19, budget 100: the incumbent of the first attempt sits at x6 = 0.699, next to the
// slab (the minimiser lies at x6 = 0.657); the refinement's level of P(success) is the incumbent's own, its contour
// passes through the incumbent, and the model's descent there points into the slab, so without the rule 7 of the 8
// refinement trials measured the incumbent again. A run without failures is unchanged (a noisy cost is left to the
// repeat: treats_cost_as_deterministic, recommender.hpp); a seed fixes the run whatever the thread count; a state
// saved inside the refinement continues exactly.
//
// failure_model.backoff_fallback (session 45; docs/failures.md, item 16): where the refinement's backoff (item 13)
// leaves no point of its box at its level of P(success), the refinement's best new point of the whole box at that
// level, not the incumbent again. Hartmann-6 with the slab 0.52 < x3 < 0.82, seed 60: the incumbent lies 0.0035 from
// the slab's face, a refinement trial 0.0006 inside it fails at trial 90, and session 42's fallback measured the
// incumbent at each of trials 91–99 (regret 0.016).
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "failing_hartmann6.hpp"
#include "varbo/algorithm.hpp"
#include "varbo/log.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {

using test::Rows;

const std::string kSlab = "{shape: box, lower: [0, 0, 0, 0, 0, 0.7], upper: [1, 1, 1, 1, 1, 1]}";
// bench_failures' "Hartmann-6, slab 0.52 < x3 < 0.82" (the minimiser at x3 = 0.477).
const std::string kSlabX3 = "{shape: box, lower: [0, 0, 0.52, 0, 0, 0], upper: [1, 1, 0.82, 1, 1, 1]}";

std::size_t col(const Rows& rows, const char* name) { return test::column(rows, name); }

std::vector<double> theta(const Rows& rows, std::size_t r) {
  std::vector<double> x;
  for (std::size_t d = 0; d < 6; ++d) x.push_back(std::stod(rows[r][col(rows, "x1") + d]));
  return x;
}

/// Refinement rows (1-based: row r is trial r - 1) whose θ equals an earlier row's θ.
std::size_t refinement_repeats(const Rows& rows) {
  std::size_t n = 0;
  for (std::size_t r = 1; r < rows.size(); ++r) {
    if (rows[r][col(rows, "phase")] != "refine") continue;
    const std::vector<double> x = theta(rows, r);
    bool seen = false;
    for (std::size_t q = 1; q < r && !seen; ++q) {
      const std::vector<double> y = theta(rows, q);
      double dist = 0;
      for (std::size_t d = 0; d < 6; ++d) dist = std::max(dist, std::abs(x[d] - y[d]));
      seen = dist < 1e-12;
    }
    n += seen;
  }
  return n;
}

std::size_t first_refinement_row(const Rows& rows) {
  for (std::size_t r = 1; r < rows.size(); ++r)
    if (rows[r][col(rows, "phase")] == "refine") return r;
  return rows.size();
}

double regret(const Rows& rows) { return std::stod(rows.back()[col(rows, "regret_recommended")]); }

}  // namespace

TEST_CASE("refine_known: the refinement does not measure a known θ of a deterministic cost again") {
  set_log_level(LogLevel::Error);
  const Rows on = test::run_hartmann6("refine_known_on", true, "", 1, 19, kSlab),
             off = test::run_hartmann6("refine_known_off", true, "{refine_known: false}", 1, 19, kSlab),
             two = test::run_hartmann6("refine_known_on", true, "", 2, 19, kSlab);
  REQUIRE(on.size() == 101);
  REQUIRE(off.size() == 101);
  const std::size_t refine = first_refinement_row(off);
  REQUIRE(refine < off.size());
  CHECK(first_refinement_row(on) == refine);
  // The runs are the same trial for trial until the refinement, whose first proposal is already the incumbent.
  CHECK(test::same_thetas(Rows(on.begin(), on.begin() + static_cast<std::ptrdiff_t>(refine)),
                          Rows(off.begin(), off.begin() + static_cast<std::ptrdiff_t>(refine))));
  CHECK(theta(on, refine) != theta(off, refine));
  CHECK(refinement_repeats(off) >= 5);
  CHECK(refinement_repeats(on) == 0);
  // The new points polish the incumbent's basin: regret 0.045 (the incumbent, measured again and again) against
  // about 1e-5 in session 44.
  CHECK(regret(off) > 0.01);
  CHECK(regret(on) < 1e-3);
  // A seed fixes the run whatever the thread count.
  CHECK(test::same_thetas(on, two));
}

TEST_CASE("backoff_fallback: a refinement held off a failure face measures new points, not the incumbent again") {
  set_log_level(LogLevel::Error);
  const Rows on = test::run_hartmann6("backoff_new", true, "", 1, 60, kSlabX3),
             off = test::run_hartmann6("backoff_incumbent", true, "{backoff_fallback: incumbent}", 1, 60, kSlabX3),
             two = test::run_hartmann6("backoff_new", true, "", 2, 60, kSlabX3);
  REQUIRE(on.size() == 101);
  REQUIRE(off.size() == 101);
  const std::size_t refine = first_refinement_row(off);
  REQUIRE(refine < off.size());
  // The first failure of the refinement; the runs are the same trial for trial until the trial after it.
  std::size_t failed = refine;
  while (failed < off.size() && off[failed][col(off, "ok")] != "0") ++failed;
  REQUIRE(failed + 1 < off.size());
  CHECK(test::same_thetas(Rows(on.begin(), on.begin() + static_cast<std::ptrdiff_t>(failed + 1)),
                          Rows(off.begin(), off.begin() + static_cast<std::ptrdiff_t>(failed + 1))));
  CHECK(refinement_repeats(off) >= 5);
  CHECK(refinement_repeats(on) == 0);
  // No more failures than session 42's fallback: the new points keep to the backoff's level.
  std::size_t failed_on = 0, failed_off = 0;
  for (std::size_t r = failed + 1; r < on.size(); ++r) {
    failed_on += on[r][col(on, "ok")] == "0";
    failed_off += off[r][col(off, "ok")] == "0";
  }
  CHECK(failed_on <= failed_off + 1);
  // The new points reach the minimiser's side of the incumbent: regret 0.016 against 0.0012 in session 45.
  CHECK(regret(off) > 0.01);
  CHECK(regret(on) < 0.005);
  CHECK(test::same_thetas(on, two));
}

TEST_CASE("refine_known: a run without failures is unchanged") {
  set_log_level(LogLevel::Error);
  const Rows free = test::run_hartmann6("refine_known_free", false, "", 1, 19, kSlab),
             free_off = test::run_hartmann6("refine_known_free_off", false, "{refine_known: false}", 1, 19, kSlab);
  REQUIRE(free.size() == 101);
  CHECK(test::same_thetas(free, free_off));
}

TEST_CASE("refine_known: a run continues from a state saved inside the refinement exactly") {
  set_log_level(LogLevel::Error);
  test::FailingHartmann6Bo run(kSlab, 19);
  std::optional<test::FailingHartmann6Bo::Saved> saved;
  std::vector<Suggestion> later;
  for (Index k = 0; k < 100; ++k) {
    const Suggestion s = run.step();
    if (saved) later.push_back(s);
    if (k == 93) saved = run.save();
  }
  REQUIRE(saved.has_value());
  CHECK(later.size() == 6);
  CHECK(later.front().phase == "refine");
  run.check_continues_as(*saved, later);
}
