#pragma once
// Draws points in a region: initial designs and acquisition candidates.
#include "varbo/region.hpp"

namespace varbo {

class Sampler {
 public:
  virtual ~Sampler();
  /// n points (rows) inside `region`, deterministic given rng's state.
  virtual Mat sample(const RegionConstraint& region, Index n, Rng& rng) const = 0;
};

}  // namespace varbo
