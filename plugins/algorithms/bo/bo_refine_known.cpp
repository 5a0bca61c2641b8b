// failure_model.refine_known (session 44; docs/failures.md, item 15) and backoff_fallback (session 45, item 16): the
// final refinement does not measure again a θ it already knows the cost of, when that cost is deterministic.
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
  const Index hit = nearest_within(evaluated_point(Box::unit(dim_).clamp(proposal)), evaluated_thetas(), 1e-9);
  if (hit < 0) return std::nullopt;
  // Under noise a repeat is a measurement (lowest_mean_evaluated's test, recommender.hpp).
  if (!deterministic_at(hit, model_y)) return std::nullopt;
  Rng rng = rng_.stream(kRefineKnown, static_cast<std::uint64_t>(k));
  const std::optional<Vec> x = new_point_at_level(acquisition, actx, p_min, model_gradients, *region_, starts, rng);
  if (x)
    log_info("bo: trial {}: the refinement's best point is trial point {}, already measured, of a deterministic "
             "cost; the attempts' acquisition's best new point under the same level of P(success) ({:.3g}) instead "
             "(refine_known)", k, hit, p_min);
  return x;
}

std::optional<Vec> BayesianOptimization::backoff_new_point(Index k, Acquisition& acquisition,
                                                           const AcquisitionContext& actx, double p_min,
                                                           bool model_gradients, const Vec& model_y) {
  // failure_model.backoff_fallback: new (session 45; docs/failures.md, item 16). After a failure of the refinement
  // its backoff (item 13) asks for a higher P(success) than the incumbent's; where the refinement's box (the last
  // attempt's converged trust region around an incumbent at a failure face) has no such point, session 42 measured
  // the incumbent again — on a deterministic cost a spent trial, and it repeats for every trial left: Hartmann-6,
  // slab 0.52 < x3 < 0.82, seed 60, the incumbent 0.0035 from the slab's face, 9 times (trials 91–99). The same
  // level over the whole box keeps the risk the backoff accepts and spends the trial where EI still expects a gain
  // (P(success) reaches the level only near the successes: far from every trial it is the design's success rate).
  if (failure_settings_.backoff_fallback != "new" || failed_.empty() || !feasibility_on_ || data_.size() == 0)
    return std::nullopt;
  Index best = 0;
  data_.y.minCoeff(&best);
  if (!deterministic_at(best, model_y)) return std::nullopt;  // under noise a repeat is a measurement
  Rng rng = rng_.stream(kBackoffNew, static_cast<std::uint64_t>(k));
  const Mat starts = starts_near(data_.X, *whole_box_, rng);
  const std::optional<Vec> x = new_point_at_level(acquisition, actx, p_min, model_gradients, *whole_box_, starts, rng);
  if (x)
    log_info("bo: trial {}: no point of the refinement's box reaches the level of P(success) {:.3g} "
             "(refine_backoff); the incumbent's cost is deterministic, so the attempts' acquisition's best new point "
             "of the whole box at that level instead (backoff_fallback: new)", k, p_min);
  return x;
}

std::optional<Vec> BayesianOptimization::new_point_at_level(Acquisition& acquisition, const AcquisitionContext& actx,
                                                            double p_min, bool model_gradients,
                                                            const RegionConstraint& region, const Mat& starts,
                                                            Rng& rng) const {
  acquisition.prepare(actx);
  FeasibilityWeightedAcquisition allowed(acquisition, *feasibility_, failure_utility(acquisition, data_.X), p_min,
                                         refine_weighted_);
  if (space_) allowed.set_evaluated_point([this](const Vec& x) { return evaluated_point(x); });
  const ValuesOnly values(allowed);
  AcquisitionFunction unscaled(model_gradients ? static_cast<const Acquisition&>(allowed) : values, dim_);
  const ScaledFunction f(unscaled, acquisition_scale(*surrogate_));
  const OptimizeResult res = optimizer_->maximize(f, region, starts, rng);
  if (!res.success || res.x.size() != dim_ || !res.x.allFinite()) return std::nullopt;
  const Vec x = Box::unit(dim_).clamp(res.x);
  const Vec at = evaluated_point(x);
  if (nearest_within(at, evaluated_thetas(), 1e-9) >= 0 || feasibility_->probability(at) < p_min) return std::nullopt;
  return x;
}

std::vector<Vec> BayesianOptimization::evaluated_thetas() const {
  std::vector<Vec> known;
  known.reserve(static_cast<std::size_t>(data_.size()));
  for (Index i = 0; i < data_.size(); ++i) known.push_back(data_.X.row(i).transpose());
  return known;
}

bool BayesianOptimization::deterministic_at(Index at, const Vec& model_y) const {
  const double noise_std = std::sqrt(surrogate_->predict(data_.X.row(at).transpose(), false).noise_var());
  return treats_cost_as_deterministic(noise_std, model_y);
}

}  // namespace varbo::bo
