// The shared restart routine (varbo/restarts.hpp): start i sees only its own stream, the reduction is in index
// order with ties keeping the lower index, and the thread count changes nothing.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include "varbo/parallel.hpp"
#include "varbo/restarts.hpp"

using namespace varbo;

namespace {
std::optional<double> score_of(double v) { return std::isnan(v) ? std::nullopt : std::optional<double>(v); }
}  // namespace

TEST_CASE("run_restarts: start i on stream i, best by a sequential reference, any thread count") {
  const Rng base(42);
  const Index n = 37;
  // Reference, sequential: three draws of stream (7, i) each.
  std::vector<double> expected;
  for (Index i = 0; i < n; ++i) {
    Rng r = base.stream(7, static_cast<std::uint64_t>(i));
    double v = 0;
    for (int j = 0; j < 3; ++j) v = r.uniform();
    expected.push_back(v);
  }
  const Index expected_best =
      static_cast<Index>(std::max_element(expected.begin(), expected.end()) - expected.begin());
  for (int threads : {1, 2}) {
    ThreadLimit limit(threads);
    const Restarts<double> run = run_restarts<double>(
        n, [&](Index i) { return base.stream(7, static_cast<std::uint64_t>(i)); },
        [](Index, Rng& r) {
          double v = 0;
          for (int j = 0; j < 3; ++j) v = r.uniform();
          return v;
        },
        score_of);
    CHECK(run.results == expected);
    CHECK(run.best == expected_best);
    CHECK(run.failed == 0);
  }
}

TEST_CASE("best_restart: ties keep the lower index; failures are counted and never win") {
  const double nan = std::nan("");
  Index failed = -1;
  CHECK(best_restart(std::vector<double>{1.0, 3.0, nan, 3.0, 2.0}, score_of, &failed) == 1);
  CHECK(failed == 1);
  CHECK(best_restart(std::vector<double>{nan, -5.0, nan}, score_of, &failed) == 1);
  CHECK(failed == 2);
  CHECK(best_restart(std::vector<double>{nan, nan}, score_of, &failed) == -1);
  CHECK(failed == 2);
  CHECK(best_restart(std::vector<double>{}, score_of) == -1);
}
