#pragma once
// Draws points in a region: initial designs and acquisition candidates.
#include "varbo/region.hpp"

namespace varbo {

/// Threads: sample() may run on several threads at once on one instance (e.g. inside an optimizer shared by a
/// surrogate's parallel fit restarts); keep per-call state local and draw only from `rng`.
class Sampler {
 public:
  virtual ~Sampler();
  /// n points (rows) inside `region`, deterministic given rng's state.
  virtual Mat sample(const RegionConstraint& region, Index n, Rng& rng) const = 0;
};

}  // namespace varbo
