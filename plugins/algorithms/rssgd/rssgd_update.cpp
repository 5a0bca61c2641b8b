#include "rssgd_update.hpp"

#include <algorithm>
#include <cmath>

namespace varbo::rssgd {

double scaled_step(const StepSize& step, double std_at_theta, double cost_unit) {
  // Section 4.1.2: η/r̃_θ kept in [min, max]; the bounds are per `cost_unit` of cost (rssgd_update.hpp).
  const double lo = step.min / cost_unit, hi = step.max / cost_unit;
  if (!(std_at_theta > 0) || !std::isfinite(std_at_theta)) return hi;
  return std::clamp(step.eta / std_at_theta, lo, hi);
}

double advantage_of(double observed_cost, const CriticEstimates& c, double kappa) {
  // Baseline J̃_θ + κ r̃_θ: the variance-minimizing baseline of eq. (18) with J_θ replaced by its estimate.
  return observed_cost - c.mean_at_theta + kappa * (c.std_at_perturbed - c.std_at_theta);  // eq. (19)
}

Vec risk_sensitive_update(const Vec& z, double observed_cost, const CriticEstimates& c, double kappa,
                          const StepSize& step, double cost_unit) {
  return -scaled_step(step, c.std_at_theta, cost_unit) * advantage_of(observed_cost, c, kappa) * z;
}

double local_cost_unit(const Vec& costs, double advantage) {
  if (costs.size() >= 2) {
    const double mean = costs.mean();
    const double sd = std::sqrt((costs.array() - mean).square().sum() / static_cast<double>(costs.size() - 1));
    if (sd > 0 && std::isfinite(sd)) return sd;
  }
  const double a = std::abs(advantage);
  return a > 0 && std::isfinite(a) ? a : 1.0;
}

CriticEstimates query_critic(const Surrogate& critic, const Vec& theta, const Vec& perturbed) {
  const Prediction at = critic.predict(theta, false);
  const Prediction pz = critic.predict(perturbed, false);
  return CriticEstimates{at.mean, at.total_std(), pz.total_std()};
}

}  // namespace varbo::rssgd
