#pragma once
// The RSSGD policy update (Kuindersma 2013, section 4.1, eq. 19 and Algorithm 3, steps d-e), as pure functions
// so the update rule can be checked apart from any model fit.
//
// Mapping of the paper's symbols to a critic surrogate's Prediction (cost units):
//   J̃_θ      = critic.predict(θ).mean                        estimated expected cost at the current policy
//   r̃_θ      = critic.predict(θ).total_std()                 predictive std of the cost Ĵ_θ, sqrt(V[Ĵ_θ | local data])
//   r̃_{θ+z}  = critic.predict(θ+z).total_std()               the same at the executed perturbation
//   Ĵ_{θ+z}  = the cost observed when θ+z was executed (not a model quantity)
// total_std() includes the latent variance c*² and the expected noise variance E[exp(g*)] (section 2.2),
// i.e. Algorithm 3's r̃² = V[Ĵ | Θ_loc, y_loc].
#include "varbo/surrogate.hpp"
#include "varbo/types.hpp"

namespace varbo::rssgd {

/// η and the range of the scaled step η / r̃_θ (paper, section 5.4: η = 0.5, η/r̃ ∈ [0.01, 0.5]).
/// The paper's range is in 1/cost units of its own tasks (costs of order 1), so a fixed range makes the step
/// depend on the cost's units: at costs ×1e4 the lower bound lets one update move θ by 100 unit cubes, at ×1e-2
/// the upper bound freezes θ. `cost_unit` is the cost difference the range refers to (η/r̃ ∈ [min, max] / unit);
/// the algorithm sets it to the spread of the local costs (option `cost_unit: auto`), which makes the update
/// independent of the cost's units and offset; 1 is the paper's literal range.
struct StepSize {
  double eta = 0.5;
  double min = 0.01;
  double max = 0.5;
};

/// The critic's estimates used by one update (Algorithm 3, step d).
struct CriticEstimates {
  double mean_at_theta = 0;     ///< J̃_θ
  double std_at_theta = 1;      ///< r̃_θ
  double std_at_perturbed = 1;  ///< r̃_{θ+z}
};

/// η / r̃_θ clamped to [min, max] / cost_unit. A non-positive or non-finite r̃_θ (a degenerate critic) gives
/// `max / cost_unit`: the clamp is what keeps the step bounded in that case (section 4.1.2, last paragraph).
double scaled_step(const StepSize& step, double std_at_theta, double cost_unit = 1);

/// Ĵ_{θ+z} − J̃_θ + κ (r̃_{θ+z} − r̃_θ): the observed cost against the baseline of eq. (19).
double advantage_of(double observed_cost, const CriticEstimates& critic, double kappa);

/// Δθ = −(η / r̃_θ) (Ĵ_{θ+z} − J̃_θ + κ (r̃_{θ+z} − r̃_θ)) z      (eq. 19, divided by r̃_θ as in Algorithm 3)
/// with η / r̃_θ clamped by scaled_step(step, r̃_θ, cost_unit).
Vec risk_sensitive_update(const Vec& z, double observed_cost, const CriticEstimates& critic, double kappa,
                          const StepSize& step, double cost_unit = 1);

/// The spread of costs that `cost_unit: auto` uses: the standard deviation of `costs` (the critic's local data);
/// when they are all equal (or fewer than two), the |advantage| of the update, so the clamp still refers to a
/// cost difference of the problem rather than to 1 in whatever units it has. 1 when both are 0.
double local_cost_unit(const Vec& costs, double advantage);

/// Reads J̃_θ, r̃_θ and r̃_{θ+z} from a fitted critic (see the mapping above).
CriticEstimates query_critic(const Surrogate& critic, const Vec& theta, const Vec& perturbed);

}  // namespace varbo::rssgd
