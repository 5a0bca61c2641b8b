#include "augmented_ei.hpp"

#include <fmt/format.h>

#include <cmath>
#include <limits>
#include <stdexcept>

#include "noise_quadrature.hpp"
#include "varbo/log.hpp"

namespace varbo::acq {

void AugmentedExpectedImprovement::prepare(const AcquisitionContext& context) {
  if (context.model == nullptr) throw std::logic_error("aei prepare(): context.model is null");
  model_ = &context.model->acquisition_model();  // warped units under an output transform
  mu_best_ = 0;
  best_ = -1;
  if (context.data == nullptr || context.data->size() == 0) {
    log_warn("aei: no evaluated points yet; using μ(x**) = 0");
    return;
  }
  // Huang et al. 2006, eq. 12: x** = argmin over the data of μ(x) + c·s(x), s the latent (kriging) std.
  double best_value = std::numeric_limits<double>::infinity();
  const Dataset& data = *context.data;
  for (Index i = 0; i < data.size(); ++i) {
    const Prediction p = model_->predict(data.X.row(i).transpose(), false);
    const double v = p.mean + c_ * std::sqrt(std::max(p.latent_var, 0.0));
    if (v < best_value) {
      best_value = v;
      best_ = i;
      mu_best_ = p.mean;
    }
  }
  if (best_ < 0) log_warn("aei: no finite prediction at the evaluated points; using μ(x**) = 0");
}

double AugmentedExpectedImprovement::evaluate(const Vec& x, Vec* grad) const {
  if (model_ == nullptr) throw std::logic_error("aei evaluate() called before prepare()");
  const Prediction p = model_->predict(x, grad != nullptr);
  const Index d = x.size();
  auto field = [d](const Vec& v) { return v.size() == d ? v : Vec(Vec::Zero(d)); };  // a GP leaves g's empty
  const double s2 = std::max(p.latent_var, 0.0);
  const double s = std::sqrt(s2);
  // EI on the latent cost: s·τ(δ/s), δ = μ(x**) − μ(x); ∂/∂δ = Φ(u), ∂/∂s = φ(u) (improvement_integrand).
  const IntegrandValue ei = improvement_integrand(mu_best_ - p.mean, s);
  double factor = 1, n = 0;
  if (noise_factor_) {
    n = p.noise_var();  // σ_ε² = E[exp(g)] = exp(μ_g + σ_g²/2)
    // n = +inf (exp overflowed): every observation there is noise, factor 0 — it was 1, the noise-free maximum.
    factor = std::isnan(n) ? n : std::isinf(n) ? 0.0 : n > 0 ? 1 - std::sqrt(n / (s2 + n)) : 1.0;
  }
  if (std::isnan(p.mean) || std::isnan(p.latent_var) || std::isnan(factor)) {  // no information: skipped
    if (grad) grad->setConstant(d, std::numeric_limits<double>::quiet_NaN());
    return std::numeric_limits<double>::quiet_NaN();
  }
  if (grad) {
    const Vec d_mean = field(p.d_mean), d_s2 = field(p.d_latent_var);
    Vec d_ei = -ei.d_delta * d_mean;
    if (s > 0) d_ei += ei.d_v * d_s2 / (2 * s);
    *grad = factor * d_ei;
    if (noise_factor_ && n > 0 && std::isfinite(n) && s2 + n > 0) {
      // factor = 1 − sqrt(r), r = n/(s² + n): ∂r = (s²·∂n − n·∂s²)/(s² + n)², ∂factor = −∂r/(2 sqrt r).
      const Vec d_n = n * (field(p.d_log_noise_mean) + 0.5 * field(p.d_log_noise_var));
      const double t = s2 + n, r = n / t;
      const Vec d_r = (s2 * d_n - n * d_s2) / (t * t);
      *grad += ei.value * (-d_r / (2 * std::sqrt(r)));
    }
  }
  return factor * ei.value;
}

std::string AugmentedExpectedImprovement::state() const {
  return fmt::format("aei: mu(x**) {:.6g} (point {}), c {:.3g}{}", mu_best_, best_, c_,
                     noise_factor_ ? "" : ", no noise factor");
}

}  // namespace varbo::acq
