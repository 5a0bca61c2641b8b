#pragma once
// The configuration of the README's GP-BO table (bench_bo_table) and of the test that guards it
// (tests/regret/test_bo_regret.cpp): one definition, so the two cannot drift apart.
#include <algorithm>
#include <limits>
#include <vector>

namespace varbo::bench {

// The plain default: what a user gets from `algorithm: {type: bo}` (issue 13). Until 2026-12 the table added 10
// initial points and a final 20-evaluation exploitation phase; the trust-region default made that phase
// unnecessary (docs/defaults.md).
inline constexpr const char* kTableAlgorithm = "{type: bo}";

/// Quantile by linear interpolation between order statistics (NaN for an empty sample).
inline double quantile(std::vector<double> v, double q) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const std::size_t lo = static_cast<std::size_t>(pos), hi = std::min(lo + 1, v.size() - 1);
  const double t = pos - static_cast<double>(lo);
  // Without the shortcut a quantile at an infinite value (a stopped run of bench_failures) reads inf − inf = nan.
  if (t == 0 || v[hi] == v[lo]) return v[lo];
  return v[lo] + t * (v[hi] - v[lo]);
}

}  // namespace varbo::bench
