#pragma once
// Initial design of cautious BO (Fröhlich et al. 2021, section 5; crbo.md "initial design"): the initial
// policy θ0 plus points on a sphere of radius r0 around it, so the first model already sees the local slope.
#include <optional>

#include "varbo/sampler.hpp"

namespace varbo::sampling {

/// Radius (unit cube) at which a single observation's latent variance under an SE kernel
/// k(r) = σ_f² exp(−r²/(2ℓ²)) reaches γ²σ_f² (noise-free data point):
///   σ²(r) = σ_f² − k(r)²/σ_f² = σ_f²(1 − exp(−r²/ℓ²))  ⇒  r0 = ℓ·sqrt(−log(1 − γ²)).
/// This is the radius of the authors' reference implementation (crbo.md); the paper's eq. (4) writes
/// r0² = −2ℓ² log(1 − γ²), which is √2 larger (see docs/crbo.md, "Which r0").
double single_point_radius_se(double lengthscale, double gamma);

struct AroundInitialPointOptions {
  double lengthscale = 0.2;  ///< ℓ (unit cube), crbo.md
  double gamma = 0.6;        ///< γ of the confidence region, crbo.md
  double radius = -1;        ///< explicit r0 (unit cube); < 0: from lengthscale and gamma
};

class AroundInitialPointSampler final : public Sampler {
 public:
  /// `center`: θ0 in the unit cube (BuildContext::initial_point); none = the centre of the region's box.
  AroundInitialPointSampler(AroundInitialPointOptions options, std::optional<Vec> center);
  /// Row 0: θ0 (clipped into the box); rows 1..n−1: θ0 + r0·u_k clipped into the box, where u_1..u_d are the
  /// columns of a random orthonormal basis, then their negatives, then random unit directions.
  /// Deterministic given rng. crbo.md's "⌈√d⌉ − 1 points around θ0" is n = ⌈√d⌉ (bo initial_points).
  Mat sample(const RegionConstraint& region, Index n, Rng& rng) const override;
  double radius() const;

 private:
  AroundInitialPointOptions options_;
  std::optional<Vec> center_;
};

}  // namespace varbo::sampling
