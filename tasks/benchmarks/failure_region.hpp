#pragma once
// A hidden failure region for benchmark tasks: trials inside it fail (ok = false, no cost), as a robot that
// falls for some controller gains. Used to test and benchmark failure-aware optimization (docs/failures.md).
// Coordinates are fractions of the task's box (0 = lower bound, 1 = upper bound in each dimension), so the
// region's volume fraction does not depend on the units.
#include <optional>
#include <string>
#include <vector>

#include "varbo/options.hpp"
#include "varbo/types.hpp"

namespace varbo::tasks {

struct FailureRegion {
  enum class Shape { Ball, Box };
  Shape shape = Shape::Ball;
  Vec center;   ///< ball
  double radius = 0;
  Vec lower, upper;  ///< box
  /// u in box fractions (the unit cube).
  bool contains(const Vec& u) const;
  std::string describe() const;
};

/// The keys of `failure_region`: {shape: ball, center: [...], radius: r} or {shape: box, lower: [...], upper: [...]}.
std::vector<OptionSpec> failure_region_options();
/// Reads the `failure_region` option of a benchmark (nullopt when absent); wrong lengths or an empty region throw
/// ConfigError naming the key.
std::optional<FailureRegion> parse_failure_region(const Options& task_options, Index dim);

}  // namespace varbo::tasks
