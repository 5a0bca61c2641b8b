#pragma once
// Cautiousness report of CRBO (Fröhlich et al. 2021, section 4.1): the radius r0 of the confidence region
// around a single evaluated point, a Lipschitz estimate L ≈ max‖∇μ_n‖ and the resulting worst-case cost of
// the next trial, cost(θ_{n+1}) ≲ cost(θ_k) + r0·L (eq. 5 written for costs, which we minimize).
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
  double r0 = 0;            ///< single-point radius for the largest lengthscale (unit cube)
  double r0_paper = 0;      ///< eq. (4) for the same lengthscale
  double lengthscale = 0;   ///< the largest lengthscale (unit cube)
  double lipschitz = 0;     ///< max ‖∇μ‖ over the data and probes (cost units per unit-cube length)
  double incumbent_mean = 0;///< μ at the evaluated point with the lowest μ
  double worst_case = 0;    ///< incumbent_mean + r0·L
  std::string text() const;
};

/// Computes the report from the fitted model and its data; `gamma` is the γ in force (after widening).
/// L is estimated on the data points and on `probes` points per data point at uniform distances ≤ r0 in random
/// directions (at most 512 probes in all), so that it covers the region the next trial can reach.
CautiousnessReport cautiousness_report(const Surrogate& model, const Dataset& data, double gamma,
                                       ReportKernel kernel, Rng& rng, int probes = 4);

}  // namespace varbo
