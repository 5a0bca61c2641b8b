#pragma once
// The configuration of the README's GP-BO table (bench_bo_table) and of the test that guards it
// (tests/regret/test_bo_regret.cpp): one definition, so the two cannot drift apart.
#include <algorithm>
#include <limits>
#include <vector>

namespace varbo::bench {

// The defaults (Latin hypercube design, gp Matérn-5/2 ARD, EI, multistart) with the last 20 evaluations
// minimizing the posterior mean (cb with κ = 0): EI keeps spending evaluations on corners of the box while the
// incumbent could still be refined (Ackley-5: median regret 1.2 without that phase, 0.11 with it).
inline constexpr const char* kTableAlgorithm =
    "{type: bo, initial_points: 10, surrogate: {type: gp}, acquisition: {type: ei}, acquisition_optimizer: "
    "{type: multistart}, phases: [{evaluations: 70}, {acquisition: {type: cb, kappa: 0}}]}";

/// Quantile by linear interpolation between order statistics (NaN for an empty sample).
inline double quantile(std::vector<double> v, double q) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const std::size_t lo = static_cast<std::size_t>(pos), hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

}  // namespace varbo::bench
