// failure_model.length_max (session 43; docs/failures.md, item 14): once a trial has failed, the trust region's side
// is at most 0.8. At its own limit (1.6, TuRBO's L_max) the box is the whole unit cube around the attempt's best, and
// EI there proposes the cube's corners; held to 0.8, every model-based trial of an attempt lies within 0.4 (∞-norm)
// of the attempt's best point at the time. Hartmann-6 with held-out box 0 of session 37 (failing_hartmann6.hpp),
// budget 100. A run without failures is unchanged; a seed fixes the run whatever the thread count; a saved state
// continues exactly (the cap is not state: bo sets it from its failed trials before every update).
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

std::size_t col(const Rows& rows, const char* name) { return test::column(rows, name); }

std::vector<double> theta(const Rows& rows, std::size_t r) {
  std::vector<double> x;
  for (std::size_t d = 0; d < 6; ++d) x.push_back(std::stod(rows[r][col(rows, "x1") + d]));
  return x;
}

/// For each model-based ("ei") trial after the first failed one: its ∞-norm distance to the best successful point of
/// its attempt before it (an attempt begins at trial 0 and at the first trial of each fresh start's design).
std::vector<double> distances_to_attempt_best(const Rows& rows) {
  std::vector<double> out;
  std::size_t start = 1;
  bool failed = false;
  const std::size_t phase = col(rows, "phase"), ok = col(rows, "ok"), cost = col(rows, "cost");
  for (std::size_t r = 1; r < rows.size(); ++r) {
    if (rows[r][phase] == "restart" && rows[r - 1][phase] != "restart") start = r;
    if (rows[r][phase] == "ei" && failed) {
      std::size_t best = 0;
      for (std::size_t q = start; q < r; ++q)
        if (rows[q][ok] == "1" && (best == 0 || std::stod(rows[q][cost]) < std::stod(rows[best][cost]))) best = q;
      if (best > 0) {
        const std::vector<double> a = theta(rows, r), b = theta(rows, best);
        double dist = 0;
        for (std::size_t d = 0; d < 6; ++d) dist = std::max(dist, std::abs(a[d] - b[d]));
        out.push_back(dist);
      }
    }
    failed = failed || rows[r][ok] == "0";
  }
  return out;
}

std::size_t beyond(const std::vector<double>& distances, double limit) {
  return static_cast<std::size_t>(
      std::count_if(distances.begin(), distances.end(), [&](double v) { return v > limit + 1e-9; }));
}

}  // namespace

TEST_CASE("length_max: once a trial has failed, an attempt's trials keep within 0.4 of its best") {
  set_log_level(LogLevel::Error);
  const Rows on = test::run_hartmann6("length_max_on", true, ""),
             off = test::run_hartmann6("length_max_off", true, "{length_max: 0}"),
             two = test::run_hartmann6("length_max_on", true, "", 2);
  REQUIRE(on.size() == 101);
  REQUIRE(off.size() == 101);
  const std::vector<double> d_on = distances_to_attempt_best(on), d_off = distances_to_attempt_best(off);
  REQUIRE(d_on.size() >= 30);
  // With the region's own limit the box grows to the whole cube and trials land up to 0.6 and more from the
  // attempt's best; with the cap none is farther than half its side.
  CHECK(beyond(d_off, 0.4) >= 3);
  CHECK(*std::max_element(d_off.begin(), d_off.end()) > 0.6);
  CHECK(beyond(d_on, 0.4) == 0);
  // The runs agree until the region would first have grown past 0.8: 3 successes after the 14-point design.
  std::size_t first = 1;
  while (first < on.size() && theta(on, first) == theta(off, first)) ++first;
  CHECK(first >= 18);
  CHECK(first < on.size());
  // A seed fixes the run whatever the thread count.
  CHECK(test::same_thetas(on, two));
}

TEST_CASE("length_max: a run without failures is unchanged") {
  set_log_level(LogLevel::Error);
  const Rows free = test::run_hartmann6("length_max_free", false, ""),
             off = test::run_hartmann6("length_max_free_off", false, "{length_max: 0}");
  REQUIRE(free.size() == 101);
  CHECK(test::same_thetas(free, off));
}

TEST_CASE("length_max: a run continues from a state saved while the cap holds the region exactly") {
  set_log_level(LogLevel::Error);
  test::FailingHartmann6Bo run;
  std::optional<test::FailingHartmann6Bo::Saved> saved;
  std::vector<Suggestion> later;
  for (Index k = 0; k < 60; ++k) {
    const Suggestion s = run.step();
    if (saved) later.push_back(s);
    if (k == 40) saved = run.save();
  }
  REQUIRE(saved.has_value());
  run.check_continues_as(*saved, later);
}
