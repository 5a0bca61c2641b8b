#include "rssgd_update.hpp"

#include <algorithm>
#include <cmath>

namespace varbo::rssgd {

double scaled_step(const StepSize& step, double std_at_theta) {
  if (!(std_at_theta > 0) || !std::isfinite(std_at_theta)) return step.max;
  return std::clamp(step.eta / std_at_theta, step.min, step.max);
}

Vec risk_sensitive_update(const Vec& z, double observed_cost, const CriticEstimates& c, double kappa,
                          const StepSize& step) {
  // Baseline J̃_θ + κ r̃_θ: the variance-minimizing baseline of eq. (18) with J_θ replaced by its estimate.
  const double advantage =
      observed_cost - c.mean_at_theta + kappa * (c.std_at_perturbed - c.std_at_theta);  // eq. (19)
  return -scaled_step(step, c.std_at_theta) * advantage * z;
}

CriticEstimates query_critic(const Surrogate& critic, const Vec& theta, const Vec& perturbed) {
  const Prediction at = critic.predict(theta, false);
  const Prediction pz = critic.predict(perturbed, false);
  return CriticEstimates{at.mean, at.total_std(), pz.total_std()};
}

}  // namespace varbo::rssgd
