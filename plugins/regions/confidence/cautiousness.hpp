#pragma once
// Cautiousness report of CRBO (Fröhlich et al. 2021, section 4.1): the radius r0 of the confidence region
// around a single evaluated point, the reach of the region around all of them (farther than r0 where the data's
// variance reductions add up), a Lipschitz estimate L ≈ max‖∇μ_n‖ and the resulting estimate of the worst cost
// of the next trial, cost(θ_{n+1}) ≲ cost(θ_k) + reach·L (eq. 5 written for costs, which we minimize).
#include <string>

#include "varbo/surrogate.hpp"

namespace varbo {

enum class ReportKernel { SquaredExponential, Matern52 };

/// Radius r at which a single noise-free observation leaves latent variance γ²σ_f², i.e. the correlation
/// ρ(r) satisfies 1 − ρ(r)² = γ² (GP posterior σ² = σ_f² − k(r)²/σ_f²). SE: r0 = ℓ·sqrt(−log(1 − γ²));
/// Matérn-5/2: solved numerically (Boost TOMS 748). +∞ when γ ≥ 1.
double single_point_radius(ReportKernel kernel, double lengthscale, double gamma);

/// The paper's eq. (4): r0 = sqrt(−2ℓ² log(1 − γ²)) (√2 larger than the SE value above, see docs/crbo.md).
double paper_radius(double lengthscale, double gamma);

struct CautiousnessReport {
  /// Single-point radius for the largest lengthscale (unit cube): the reach of the region around a LONE noise-free
  /// observation. Not a bound once there are several: where the data's variance reductions add up, the region
  /// extends farther than r0 from every evaluated point (issue 12, item 10).
  double single_point_r0 = 0;
  double r0_paper = 0;      ///< eq. (4) for the same lengthscale
  double lengthscale = 0;   ///< the largest lengthscale (unit cube)
  /// The largest distance from the nearest evaluated point of a region point found on rays from the data: how far
  /// the next trial can land from every earlier one, as far as the search found (a lower estimate of the reach).
  double reach = 0;
  double lipschitz = 0;     ///< max ‖∇μ‖ over the data and probes (cost units per unit-cube length)
  double incumbent_mean = 0;///< μ at the evaluated point with the lowest μ
  double worst_case = 0;    ///< incumbent_mean + reach·L: eq. (5) with the measured reach in place of r0
  std::string text() const;
};

/// Computes the report from the fitted model and its data; `gamma` is the γ in force (after widening): θ is in
/// the region when latent_var(θ) ≤ γ²σ_f². The reach is searched on up to 256 rays from the data points (random
/// directions, steps of r0/2 up to 4·r0, the boundary refined by bisection). L is estimated on the data points and
/// on `probes` points per data point at uniform distances ≤ max(r0, reach) in random directions (at most 512
/// probes in all), so that it covers the region the next trial can reach.
CautiousnessReport cautiousness_report(const Surrogate& model, const Dataset& data, double gamma,
                                       ReportKernel kernel, Rng& rng, int probes = 4);

}  // namespace varbo
