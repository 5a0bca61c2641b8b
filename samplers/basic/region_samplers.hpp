#pragma once
// The Sampler components: unit-cube designs mapped to the region's box, with rejection of points outside
// the region's constraint.
#include <functional>

#include "unit_designs.hpp"
#include "varbo/sampler.hpp"

namespace varbo::sampling {

/// Draws unit-cube points in batches from `next_batch(k)` (k = how many are still missing), maps them to
/// region.bounds() and keeps those with region.contains(x). Stops after `max_draws` draws; then returns the
/// points found (possibly fewer than n) and logs a warning naming `who`.
Mat fill_region(const RegionConstraint& region, Index n, const std::function<Mat(Index)>& next_batch,
                Index max_draws, const char* who);

/// Draws per requested point before giving up on a constrained region.
constexpr Index kMaxDrawsPerPoint = 200;

class UniformSampler final : public Sampler {
 public:
  Mat sample(const RegionConstraint& region, Index n, Rng& rng) const override;
};

class LatinHypercubeSampler final : public Sampler {
 public:
  Mat sample(const RegionConstraint& region, Index n, Rng& rng) const override;
};

class SobolSampler final : public Sampler {
 public:
  explicit SobolSampler(bool scramble) : scramble_(scramble) {}
  Mat sample(const RegionConstraint& region, Index n, Rng& rng) const override;

 private:
  bool scramble_;
};

}  // namespace varbo::sampling
