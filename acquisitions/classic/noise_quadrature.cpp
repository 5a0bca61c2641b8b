#include "noise_quadrature.hpp"

#include <cmath>
#include <limits>

#include "normal_tail.hpp"
#include "varbo/math.hpp"

namespace varbo::acq {

IntegrandValue improvement_integrand(double delta, double v) {
  IntegrandValue r;
  if (!(v > 0)) {  // no uncertainty left: the improvement is deterministic
    r.value = std::max(delta, 0.0);
    r.d_delta = delta > 0 ? 1.0 : 0.0;
    r.d_v = delta == 0 ? normal_pdf(0.0) : 0.0;
    return r;
  }
  const double u = delta / v;  // may be ±inf for v tiny: handled by the helpers below
  if (std::isinf(u)) {
    r.value = u > 0 ? delta : 0.0;
    r.d_delta = u > 0 ? 1.0 : 0.0;
    return r;
  }
  r.value = v * normal_expected_positive_part(u);
  r.d_delta = normal_cdf(u);
  r.d_v = normal_pdf(u);
  return r;
}

IntegrandValue probability_integrand(double delta, double v) {
  IntegrandValue r;
  if (!(v > 0)) {
    r.value = delta > 0 ? 1.0 : (delta == 0 ? 0.5 : 0.0);
    return r;
  }
  const double u = delta / v;
  r.value = normal_cdf(u);
  if (std::isinf(u)) return r;
  const double pdf = normal_pdf(u);
  r.d_delta = pdf / v;   // dΦ(δ/v)/dδ
  r.d_v = -pdf * u / v;  // dΦ(δ/v)/dv
  return r;
}

double expect_over_log_noise(const Prediction& pred, double delta, const Vec* d_delta, const GaussHermite& gh,
                             Integrand integrand, Vec* grad) {
  // A NaN anywhere in the predictive is no information, not certainty: std::max(NaN, 0) and !(v > 0) turned a
  // NaN variance into "no spread", i.e. EI = the full improvement and PI = 1 (red team, session 27). NaN lets
  // the acquisition optimizers skip the point, as they do for cb and eri.
  if (std::isnan(delta) || std::isnan(pred.latent_var) || std::isnan(pred.log_noise_mean) ||
      std::isnan(pred.log_noise_var)) {
    if (grad) grad->setConstant(d_delta ? d_delta->size() : 0, std::numeric_limits<double>::quiet_NaN());
    return std::numeric_limits<double>::quiet_NaN();
  }
  const double c2 = std::max(pred.latent_var, 0.0);
  // Below 1e-20 the log-noise spread changes nothing a double can hold, and the quadrature's ∂/∂σ*² cancels
  // catastrophically (t_k/√(2σ*²) summed over symmetric nodes: −1e133 at σ*² = 1e-300): the homoscedastic form.
  if (!(pred.log_noise_var > 1e-20)) {
    // Homoscedastic special case: y* ~ N(a*, c*² + e^μ*), no quadrature.
    const double v = std::sqrt(c2 + std::exp(pred.log_noise_mean));
    const IntegrandValue F = integrand(delta, v);
    if (grad) {
      *grad = F.d_delta * (*d_delta);
      if (v > 0 && F.d_v != 0)
        *grad += F.d_v / (2 * v) * (pred.d_latent_var + std::exp(pred.log_noise_mean) * pred.d_log_noise_mean);
    }
    return F.value;
  }
  // Kuindersma 2013, eq. (9): g_k = μ* + √(2σ*²) t_k with weights w_k/√π for the weight e^{−t²}.
  const double scale = std::sqrt(2.0 * pred.log_noise_var);
  const double inv_sqrt_pi = 1.0 / std::sqrt(M_PI);
  double value = 0, sum_d_delta = 0;
  // Accumulated coefficients of the gradient: dE = A dδ + B dc*² + C dμ* + D dσ*².
  double B = 0, C = 0, D = 0;
  for (Index k = 0; k < gh.nodes.size(); ++k) {
    const double w = gh.weights[k] * inv_sqrt_pi;
    const double t = gh.nodes[k];
    const double noise = std::exp(pred.log_noise_mean + scale * t);
    const double v = std::sqrt(c2 + noise);
    const IntegrandValue F = integrand(delta, v);
    value += w * F.value;
    if (grad) {
      sum_d_delta += w * F.d_delta;
      if (v > 0) {
        const double dv_common = w * F.d_v / (2 * v);  // ∂v/∂c*² = 1/(2v), ∂v/∂g = e^g/(2v)
        B += dv_common;
        C += dv_common * noise;
        D += dv_common * noise * t / scale;            // ∂g_k/∂σ*² = t_k/√(2σ*²)
      }
    }
  }
  if (grad) {
    *grad = sum_d_delta * (*d_delta) + B * pred.d_latent_var + C * pred.d_log_noise_mean +
            D * pred.d_log_noise_var;
  }
  return value;
}

}  // namespace varbo::acq
