// failure_model.refine_known (session 44; docs/failures.md, item 15): the final refinement does not measure again a
// θ it already knows the cost of, when that cost is deterministic.
#include <cmath>
#include <vector>

#include "acquisition_scale.hpp"
#include "bayesian_optimization.hpp"
#include "bo_streams.hpp"
#include "failure_aware.hpp"
#include "pending_exclusion.hpp"
#include "recommender.hpp"
#include "values_only.hpp"
#include "varbo/log.hpp"

namespace varbo::bo {

std::optional<Vec> BayesianOptimization::refine_past_known(Index k, Acquisition& acquisition,
                                                           const AcquisitionContext& actx, double p_min,
                                                           bool model_gradients, const Mat& starts,
                                                           const Vec& proposal, const Vec& model_y) {
  // The refinement minimizes the posterior mean where P(success) reaches the incumbent's level (item 4), and that
  // level's contour passes through the incumbent itself. Where the model's descent at the incumbent points towards
  // the failures, the constrained minimum is the incumbent: Hartmann-6 with the slab x6 > 0.7, seed 19 — the
  // incumbent at x6 = 0.699 (the minimiser lies at 0.657), 7 of the 8 refinement trials measured it again, each
  // the same cost. On a deterministic cost such a trial teaches nothing; the attempts' acquisition (EI by default)
  // is zero there and positive where the model still expects a gain, under the same level.
  if (!failure_settings_.refine_known || failed_.empty() || !feasibility_on_ || data_.size() == 0) return std::nullopt;
  std::vector<Vec> known;
  known.reserve(static_cast<std::size_t>(data_.size()));
  for (Index i = 0; i < data_.size(); ++i) known.push_back(data_.X.row(i).transpose());
  const Index hit = nearest_within(evaluated_point(Box::unit(dim_).clamp(proposal)), known, 1e-9);
  if (hit < 0) return std::nullopt;
  // Under noise a repeat is a measurement (lowest_mean_evaluated's test, recommender.hpp).
  const double noise_std = std::sqrt(surrogate_->predict(known[static_cast<std::size_t>(hit)], false).noise_var());
  if (!treats_cost_as_deterministic(noise_std, model_y)) return std::nullopt;
  acquisition.prepare(actx);
  FeasibilityWeightedAcquisition allowed(acquisition, *feasibility_, failure_utility(acquisition, data_.X), p_min,
                                         refine_weighted_);
  if (space_) allowed.set_evaluated_point([this](const Vec& x) { return evaluated_point(x); });
  const ValuesOnly values(allowed);
  AcquisitionFunction unscaled(model_gradients ? static_cast<const Acquisition&>(allowed) : values, dim_);
  const ScaledFunction f(unscaled, acquisition_scale(*surrogate_));
  Rng rng = rng_.stream(kRefineKnown, static_cast<std::uint64_t>(k));
  const OptimizeResult res = optimizer_->maximize(f, *region_, starts, rng);
  if (!res.success || res.x.size() != dim_ || !res.x.allFinite()) return std::nullopt;
  const Vec x = Box::unit(dim_).clamp(res.x);
  const Vec at = evaluated_point(x);
  if (nearest_within(at, known, 1e-9) >= 0 || feasibility_->probability(at) < p_min) return std::nullopt;
  log_info("bo: trial {}: the refinement's best point is trial point {}, already measured, of a deterministic cost; "
           "the attempts' acquisition's best new point under the same level of P(success) ({:.3g}) instead "
           "(refine_known)", k, hit, p_min);
  return x;
}

}  // namespace varbo::bo
