#pragma once
// Hit-and-run sampling of box ∩ region (Bélisle et al. 1993; Fröhlich et al. 2021, Alg. 1): from the current
// point draw a uniformly random direction, find the chord of the region along it, and move to a uniform point
// on the chord. The chord is bracketed by stepping out with doubling and sampled by shrinkage (Neal 2003,
// "Slice sampling", sections 4.1–4.2), with the box limits computed exactly.
//
// Across calls (one per BO iteration) the chains and the samples are kept, as in the authors' reference
// implementation (crbo.md: 256 chains, half of the 1000 samples refreshed each iteration): a chain whose point is
// still inside the (updated) region continues from it, so the chains are near their stationary law after a few
// iterations instead of 10 steps away from the data at every one (issue 12, item 10).
#include <mutex>
#include <vector>

#include "varbo/sampler.hpp"
#include "varbo/state.hpp"

namespace varbo {

struct HitAndRunOptions {
  Index chains = 256;     ///< parallel chains (fewer when fewer samples are asked for)
  Index burn_in = 10;     ///< steps of each chain before its first sample
  Index thinning = 1;     ///< steps between kept samples
  double width = 0.1;     ///< initial bracket width w (unit cube), crbo.md
  int max_doublings = 10; ///< crbo.md
  int max_shrinks = 50;   ///< rejections per chord before the chain stays put, crbo.md
  /// Fraction of the samples drawn anew by each call; the rest are the previous call's newest samples that are
  /// still inside the region (crbo.md: half). 1: every sample new.
  double refresh = 0.5;
  /// Continue each chain from where the previous call left it (if still inside); false: every call restarts
  /// the chains from the seeds with `burn_in` steps.
  bool keep_chains = true;
};

/// Counters of one sample() call (for tests and logs).
struct HitAndRunStats {
  Index steps = 0;
  Index stuck = 0;          ///< steps where all shrinks were rejected (the chain stayed put)
  Index evaluations = 0;    ///< region.contains calls
};

class HitAndRunSampler final : public Sampler, public ComponentState {
 public:
  explicit HitAndRunSampler(HitAndRunOptions options);
  /// n points inside `region`. A chain continues from its point of the previous call when that is still inside;
  /// otherwise (and on the first call) it starts at a seed drawn from its own stream among all region.seeds()
  /// that lie inside, else at the box centre if it is inside, else at the first of 1000 uniform box points that
  /// is, and takes `burn_in` steps; throws NumericalError if no start is found. Chain c uses its own stream, so
  /// the result depends on the seed and the sequence of calls, never on the thread count. Calls are serialized.
  Mat sample(const RegionConstraint& region, Index n, Rng& rng) const override;
  Mat sample(const RegionConstraint& region, Index n, Rng& rng, HitAndRunStats* stats) const;
  const HitAndRunOptions& options() const { return options_; }
  /// Exact snapshot of what the chains carry between calls (hit_and_run_state.cpp).
  std::string save_state() const override;
  void restore_state(const std::string& state) override;

  /// One hit-and-run move from x (inside region) — exposed for tests.
  Vec step(const RegionConstraint& region, const Vec& x, Rng& rng, HitAndRunStats* stats) const;

 private:
  /// Feasible starting points: the seeds inside the region, else one fallback point (see sample()).
  std::vector<Vec> starts_for(const RegionConstraint& region, const Rng& base) const;

  HitAndRunOptions options_;
  // What the chains carry from one call to the next.
  mutable std::mutex mutex_;
  mutable std::vector<Vec> chains_;  ///< each chain's last point (empty: not started)
  mutable Mat previous_;             ///< the previous call's samples, newest first
};

}  // namespace varbo
