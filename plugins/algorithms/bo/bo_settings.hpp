#pragma once
// bo's own settings: the member initializers below are the defaults of its top-level options (one source,
// option_set.hpp). Component options (surrogate, acquisition, region, ...) and the `phases` / `failure_model`
// maps are declared beside them in bo_options() but parsed by hand.
#include <optional>
#include <string>

#include "recommender.hpp"
#include "varbo/option_set.hpp"

namespace varbo::bo {

/// How points of a batch (and points pending elsewhere) enter the model before they are observed
/// (Ginsbourger, Le Riche & Carraro 2010, section 3).
enum class BatchStrategy { KrigingBeliever, ConstantLiarMin, ConstantLiarMean };

struct BoSettings {
  Index initial_points = -1;  ///< initial design size; -1 = 2·(d+1), capped by the budget
  Index refit_every = 1;      ///< optimize hyperparameters every k model iterations (else only condition)
  Index refine_last = -1;     ///< after fresh starts, the last trials refine the incumbent; -1 = d + 1
  Index restart_points = -1;  ///< design size of a fresh start; -1 = initial_points
  /// A fresh start's design: a new LHS, or (away, the default since session h6b) the one of 16 LHS farthest from
  /// earlier attempts' minima: Hartmann-6 stuck in 3 of seeds 1–20 instead of 7 (docs/defaults.md).
  std::string restart_design = "away";
  /// The final refinement's model: all the data, the incumbent's attempt, or (basin, the default since session h6b)
  /// the attempt plus every point near the incumbent: Hartmann-6's late global basins refined (q3 0.033 → 0.0033)
  /// without the attempt model's loss on Branin (docs/defaults.md).
  std::string refine_model = "basin";
  /// Begin the final refinement as soon as no later attempt could fit in the budget, when the current attempt holds
  /// the incumbent (session h6med): Hartmann-6's median 1.7e-06 → 6.4e-07, Branin, Hartmann-3, Ackley-5 unchanged.
  bool refine_early = true;
  /// The last point of the initial design and of each fresh start's design repeats its first: an exact replicate,
  /// so that a surrogate's test for noise on the data (gp's noise_test_level) sees from the start whether the cost
  /// is deterministic (docs/defaults.md, "Session se15"). Not given: as the surrogate asks
  /// (Surrogate::tests_noise_on_replicates: a gp with a noise test, by default the one with kernel se_ard).
  std::optional<bool> replicate_design;
  std::string refine_feasibility = "exclude";  ///< with failures, the refinement excludes (or weights by) P(fail)
  double epsilon = 0.0;       ///< probability of a random point instead of the acquisition's choice
  BatchStrategy batch_strategy = BatchStrategy::KrigingBeliever;
  /// A model-based suggestion within this distance (∞-norm, unit cube) of a pending point (another worker's, or
  /// earlier in the batch) is searched again away from it (pending_exclusion.hpp); 0 = allowed.
  double pending_distance = 1e-3;
  RecommendationRule recommendation = RecommendationRule::LowestMeanEvaluated;
  double recommendation_kappa = 1.0;  ///< κ of lowest_bound_evaluated
};

/// Every top-level option of `bo`, in the order --describe shows them; the BoSettings fields are bound.
const OptionSet<BoSettings>& bo_options();

}  // namespace varbo::bo
