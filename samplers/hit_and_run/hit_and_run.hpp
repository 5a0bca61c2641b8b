#pragma once
// Hit-and-run sampling of box ∩ region (Bélisle et al. 1993; Fröhlich et al. 2021, Alg. 1): from the current
// point draw a uniformly random direction, find the chord of the region along it, and move to a uniform point
// on the chord. The chord is bracketed by stepping out with doubling and sampled by shrinkage (Neal 2003,
// "Slice sampling", sections 4.1–4.2), with the box limits computed exactly.
#include "varbo/sampler.hpp"

namespace varbo {

struct HitAndRunOptions {
  Index chains = 256;     ///< parallel chains (fewer when fewer samples are asked for)
  Index burn_in = 10;     ///< steps of each chain before its first sample
  Index thinning = 1;     ///< steps between kept samples
  double width = 0.1;     ///< initial bracket width w (unit cube), crbo.md
  int max_doublings = 10; ///< crbo.md
  int max_shrinks = 50;   ///< rejections per chord before the chain stays put, crbo.md
};

/// Counters of one sample() call (for tests and logs).
struct HitAndRunStats {
  Index steps = 0;
  Index stuck = 0;          ///< steps where all shrinks were rejected (the chain stayed put)
  Index evaluations = 0;    ///< region.contains calls
};

class HitAndRunSampler final : public Sampler {
 public:
  explicit HitAndRunSampler(HitAndRunOptions options);
  /// n points inside `region`. Chains start from region.seeds() that lie inside (round-robin), else from the
  /// box centre if it is inside, else from the first of 1000 uniform box points that is; throws
  /// NumericalError if none is found. Chain c uses its own stream, so the result does not depend on threads.
  Mat sample(const RegionConstraint& region, Index n, Rng& rng) const override;
  Mat sample(const RegionConstraint& region, Index n, Rng& rng, HitAndRunStats* stats) const;
  const HitAndRunOptions& options() const { return options_; }

  /// One hit-and-run move from x (inside region) — exposed for tests.
  Vec step(const RegionConstraint& region, const Vec& x, Rng& rng, HitAndRunStats* stats) const;

 private:
  HitAndRunOptions options_;
};

}  // namespace varbo
