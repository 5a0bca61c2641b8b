#pragma once
// Expectations over the log noise g* of a Prediction, for improvement-type integrands F(δ, v):
//   ∫ F(δ, v(g)) N(g | μ*, σ*²) dg,   v(g)² = c*² + e^g     (Kuindersma 2013, eq. 9 and 12)
// by Gauss–Hermite quadrature, or in closed form when σ*² = 0 (homoscedastic: v² = c*² + e^μ*).
// δ (the "improvement margin", e.g. μ_best − a* + ξ) does not depend on g; its gradient is passed in.
#include "varbo/math.hpp"
#include "varbo/prediction.hpp"

namespace varbo::acq {

/// F and its partial derivatives at one (δ, v).
struct IntegrandValue {
  double value = 0;
  double d_delta = 0;  ///< ∂F/∂δ
  double d_v = 0;      ///< ∂F/∂v
};

/// EI integrand v·τ(δ/v) = v(uΦ(u) + φ(u)), u = δ/v; ∂/∂δ = Φ(u), ∂/∂v = φ(u). The limit v → 0 is max(δ, 0).
IntegrandValue improvement_integrand(double delta, double v);
/// PI integrand Φ(δ/v); the limit v → 0 is the step 1[δ > 0].
IntegrandValue probability_integrand(double delta, double v);

using Integrand = IntegrandValue (*)(double delta, double v);

/// E_g[F(δ, v(g))]. With grad non-null, fills d/dθ* from pred's d_* fields (which must be present) and
/// d_delta: the derivative under the integral, dF = F_δ dδ + F_v dv, with dv_k = (dc*² + e^{g_k} dg_k)/(2 v_k)
/// and g_k = μ* + √(2σ*²)·t_k, so dg_k = dμ* + t_k dσ*²/√(2σ*²) (the paper's z(ρ) after eq. 9).
/// `rule` is the Gauss–Hermite rule (weight e^{−t²}), e.g. gauss_hermite(45); unused when σ*² = 0.
double expect_over_log_noise(const Prediction& pred, double delta, const Vec* d_delta, const GaussHermite& rule,
                             Integrand integrand, Vec* grad);

}  // namespace varbo::acq
