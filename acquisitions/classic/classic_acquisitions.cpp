#include "classic_acquisitions.hpp"

#include <fmt/format.h>

#include <cmath>
#include <stdexcept>

#include "noise_quadrature.hpp"
#include "varbo/log.hpp"

namespace varbo::acq {

namespace {
const Surrogate& require_model(const AcquisitionContext& context) {
  if (context.model == nullptr) throw std::logic_error("acquisition prepare(): context.model is null");
  return context.model->acquisition_model();  // warped units under an output transform
}
const Surrogate& prepared(const Surrogate* model) {
  if (model == nullptr) throw std::logic_error("acquisition evaluate() called before prepare()");
  return *model;
}
// Surrogates may leave gradient fields they do not model empty (a GP has no log-noise gradient): zeros.
Prediction predict(const Surrogate* model, const Vec& x, bool with_gradient) {
  Prediction p = prepared(model).predict(x, with_gradient);
  if (with_gradient) {
    for (Vec* d : {&p.d_mean, &p.d_latent_var, &p.d_log_noise_mean, &p.d_log_noise_var})
      if (d->size() != x.size()) {
        if (d->size() != 0)
          throw std::logic_error("surrogate returned a gradient of the wrong size (" + std::to_string(d->size()) +
                                 " for dimension " + std::to_string(x.size()) + ")");
        *d = Vec::Zero(x.size());
      }
  }
  return p;
}
// s* = sqrt(V[y*]) and its gradient ds* = dV/(2 s*) (zero where V = 0, where s* is not differentiable).
double predictive_std(const Prediction& p, Vec* d_std) {
  const double s = p.total_std();
  if (d_std) *d_std = s > 0 ? Vec(p.d_total_var() / (2 * s)) : Vec(Vec::Zero(p.d_mean.size()));
  return s;
}
}  // namespace

double signal_std(const Surrogate& model) {
  const double var = model.signal_variance();
  return std::isfinite(var) && var > 0 ? std::sqrt(var) : 0.0;
}

Target find_target(const AcquisitionContext& context, double kappa) {
  const Surrogate& model = require_model(context);
  Target t;
  if (context.data == nullptr || context.data->size() == 0) {
    log_warn("acquisition: no evaluated points yet; using μ_best = 0, s_best = 0");
    return t;
  }
  const Incumbent inc = find_incumbent(model, *context.data, kappa);
  if (inc.index < 0) {  // every prediction was NaN
    log_warn("acquisition: no finite prediction at the evaluated points; using μ_best = 0, s_best = 0");
    return t;
  }
  t.mu_best = inc.mean;
  t.s_best = inc.std;
  t.index = inc.index;
  return t;
}

// ---- EI, PI ----
void ImprovementAcquisition::prepare(const AcquisitionContext& context) {
  model_ = &require_model(context);
  target_ = find_target(context, 0.0);
  // ξ ≥ 0 asks for an improvement of at least ξ·σ_f, i.e. more exploration, as the paper intends for its
  // "exploration parameter". Its printed formula u = (μ_best − a* + ξ)/v has the opposite sign, which makes the
  // incumbent a local maximum of EI for any ξ > 0 (a local acquisition search then never leaves it); the
  // reference values for that form are reproduced with ξ = −0.01 in the tests.
  margin_ = target_.mu_best - xi_ * signal_std(*model_);
}

double ImprovementAcquisition::evaluate(const Vec& x, Vec* grad) const {
  const Prediction p = predict(model_, x, grad != nullptr);
  // Kuindersma 2013, eq. (9): u = (μ_best − a* − ξσ_f)/v* (sign of ξ: see prepare()).
  const double delta = margin_ - p.mean;
  const Vec d_delta = grad ? Vec(-p.d_mean) : Vec();
  return expect_over_log_noise(p, delta, &d_delta, rule_, integrand_, grad);
}

std::string ImprovementAcquisition::state() const {
  return fmt::format("{}: mu_best {:.6g} (point {}), target {:.6g}", name_, target_.mu_best, target_.index, margin_);
}

// ---- CB ----
void ConfidenceBound::prepare(const AcquisitionContext& context) {
  model_ = &require_model(context);
  if (randomize_) {
    // Randomized CB: κ ~ N(0, 1) per iteration, from the iteration's own stream.
    if (context.rng != nullptr) {
      kappa_ = context.rng->normal();
    } else {
      Rng fallback(mix_seed(0xCBu, static_cast<std::uint64_t>(context.iteration)));
      kappa_ = fallback.normal();
      log_warn("cb: randomize without an rng in the context; drew kappa from the iteration number");
    }
  }
}

double ConfidenceBound::evaluate(const Vec& x, Vec* grad) const {
  const Prediction p = predict(model_, x, grad != nullptr);
  Vec d_std;
  const double s = predictive_std(p, grad ? &d_std : nullptr);
  // Kuindersma 2013, eq. (10) with b(V, κ) = κ·s*; utility = −CB.
  if (grad) *grad = -(p.d_mean + kappa_ * d_std);
  return -(p.mean + kappa_ * s);
}

std::string ConfidenceBound::state() const {
  return fmt::format("cb: kappa {:.6g}{}", kappa_, randomize_ ? " (randomized)" : "");
}

// ---- ERI ----
void ExpectedRiskImprovement::prepare(const AcquisitionContext& context) {
  model_ = &require_model(context);
  target_ = find_target(context, kappa_);
  margin_ = target_.mu_best + kappa_ * target_.s_best - xi_ * signal_std(*model_);  // eq. (12)
}

double ExpectedRiskImprovement::evaluate(const Vec& x, Vec* grad) const {
  const Prediction p = predict(model_, x, grad != nullptr);
  Vec d_std;
  const double s = predictive_std(p, grad ? &d_std : nullptr);
  // Kuindersma 2013, eq. (12): u* = (μ_best − a* + κ(s_best − s*))/v*; s* is not integrated over g*.
  const double delta = margin_ - p.mean - kappa_ * s;
  const Vec d_delta = grad ? Vec(-p.d_mean - kappa_ * d_std) : Vec();
  return expect_over_log_noise(p, delta, &d_delta, rule_, improvement_integrand, grad);
}

std::string ExpectedRiskImprovement::state() const {
  return fmt::format("eri: kappa {:.6g}, mu_best {:.6g}, s_best {:.6g} (point {})", kappa_, target_.mu_best,
                     target_.s_best, target_.index);
}

}  // namespace varbo::acq
