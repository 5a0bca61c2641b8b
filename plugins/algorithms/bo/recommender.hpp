#pragma once
// What a BO run recommends: the θ a user deploys after the last trial. It is chosen on a model conditioned on
// *all* observations (the fitted model of the last ask() saw N − 1 of them, and the last point still carries
// the optimistic prediction that got it chosen), by one of the rules users expect.
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "varbo/search_space.hpp"
#include "varbo/registry.hpp"

namespace varbo::bo {

enum class RecommendationRule {
  LowestMeanEvaluated,  ///< the evaluated θ with the lowest posterior mean (default)
  LowestMeanDomain,     ///< argmin of the posterior mean over the search region (optimized)
  LowestBoundEvaluated, ///< the evaluated θ with the lowest E + κ·s (κ > 0: risk-averse, Kuindersma 2013 eq. 12)
  BestObserved,         ///< the evaluated θ with the lowest observed cost (no model)
};

/// The option values of `recommendation`, in declaration order (the first is the default).
const std::vector<std::string>& recommendation_rule_names();
RecommendationRule recommendation_rule(const std::string& name);

/// The rule `lowest_mean_evaluated`: the index of the evaluated point with the lowest posterior mean, ties
/// within a tenth of the noise std broken by the lowest observed cost; the lowest observed cost outright when the
/// model's noise is at most 1e-5 of std(y), i.e. it treats the cost as deterministic (recommender.cpp says why).
Index lowest_mean_evaluated(const Surrogate& model, const Dataset& data);

/// Whether a model with noise std `noise_std` treats costs `y` as deterministic: the noise at most 1e-5 of their
/// standard deviation (the recommendation, failure_model.repeat_distance and refine_known use this test; needs ≥ 2
/// costs).
bool treats_cost_as_deterministic(double noise_std, const Vec& y);

/// Sets `target` up to be conditioned on `n` points with `fitted`'s hyperparameters: all but a constant mean, and
/// VHGP's per-point log Λ for the first n points (the latest fit's, new points at their median).
void take_fitted_hyperparameters(const Surrogate& fitted, Surrogate& target, Index n);

/// P(success | x) with its gradient (the failure model's classifier fitted on every trial), and the level a
/// LowestMeanDomain recommendation must reach: min(cap, P at the evaluated point it would replace). Empty: no model.
struct SuccessOdds {
  std::function<double(const Vec& x, Vec* grad)> probability;
  double cap = 0.8;
  explicit operator bool() const { return static_cast<bool>(probability); }
};

class Recommender {
 public:
  /// `model` is a second instance of the run's surrogate: it is conditioned (or refitted) on all data and
  /// never touches the run's own model, so recommending changes no trial.
  Recommender(RecommendationRule rule, double kappa, std::unique_ptr<Surrogate> model);

  /// Recommended θ (unit cube) for `data`. `fitted` is the run's model after its latest fit (its
  /// hyperparameters and state seed the recommendation model), or nullptr when there is none. With `refit`
  /// the recommendation model's hyperparameters are optimized on all data (the run's final recommendation);
  /// otherwise it is conditioned with the fitted hyperparameters. `region` and `optimizer` serve
  /// LowestMeanDomain, which keeps away from `failed` (θ of failed trials, unit cube, one per row; may be empty).
  /// Results are cached per data size, failure count and refit flag.
  Vec recommend(const Surrogate* fitted, const Dataset& data, const Mat& failed, const RegionConstraint& region,
                const Optimizer& optimizer, Rng& rng, bool refit, const SuccessOdds& success = {});

  RecommendationRule rule() const { return rule_; }
  /// Wraps the recommendation model so that it sees integers and categories rounded (varbo/space_wrappers.hpp);
  /// nothing for a null space or one without them.
  void wrap_model(const SharedSpace& space);
  /// The recommendation model after the latest recommend() (nullptr if none was usable).
  const Surrogate* model() const { return ready_ ? model_.get() : nullptr; }

 private:
  bool prepare_model(const Surrogate& fitted, const Dataset& data, Rng& rng, bool refit);

  RecommendationRule rule_;
  double kappa_;
  std::unique_ptr<Surrogate> model_;
  bool ready_ = false;
  Index cached_n_ = -1;
  Index cached_failed_ = -1;
  bool cached_refit_ = false;
  Vec cached_;
};

}  // namespace varbo::bo
