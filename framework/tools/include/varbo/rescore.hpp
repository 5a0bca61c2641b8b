#pragma once
// Offline re-weighting of a finished run and risk-sensitive re-selection of a policy (Kuindersma 2013,
// section 5.4.2): recompute every trial's cost under new component weights (eq. 23), fit a local model of the
// cost distribution around the learned policy, and select policies minimizing J̃(θ) + κ r̃(θ) for each κ —
// without new trials. Used by `varbo rescore`.
//
// Weights convention: a task's cost is Σ_c w_c · component_c. The run's weights are its task's `weights:`
// option (config.resolved.yaml) where present; a component without a listed weight has weight 1 (so tasks
// whose components are already weighted, and whose cost is their plain sum, rescore correctly too).
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "varbo/registry.hpp"
#include "varbo/select.hpp"
#include "varbo/study.hpp"

namespace varbo {

struct RunFolder;  // varbo/run_folder.hpp

using Weights = std::map<std::string, double>;

/// A finished run with its cost components (successful trials only).
struct ComponentRun {
  std::string folder;
  StudyConfig study;
  Domain domain;
  std::vector<std::string> components;  ///< trials.csv component columns, in the task's order
  Mat theta;                            ///< user units, one row per successful trial
  Mat unit;                             ///< the same in the unit cube
  Vec cost;                             ///< recorded costs
  Mat values;                           ///< component values, rows × components
  Weights weights;                      ///< the run's weights (see the convention above)
  std::optional<Vec> recommended;       ///< summary.json recommended_theta (user units)
  std::optional<Vec> best;              ///< summary.json best_theta (user units)
  std::optional<Vec> initial_point;     ///< config initial_point, else the task's (user units)
};

/// Reads config.resolved.yaml, trials.csv and summary.json of `folder`. Throws InputError/ConfigError.
ComponentRun load_component_run(const std::string& folder, const Registry& registry);

/// The successful trials with every component of a run already read (a run folder, or a study seen as one by
/// `varbo dashboard`); `label` names it in errors. Leaves `recommended` and `best` empty.
ComponentRun component_run_from(const RunFolder& run, const std::string& label);

/// Sets `recommended` and `best` from a summary.json, when the file exists. InputError when it does not parse.
void read_run_summary(ComponentRun& run, const std::string& summary);

/// Parses "energy=0.1,tracking=1"; every name must be one of `components`, every weight finite and >= 0.
Weights parse_weight_list(const std::string& text, const std::vector<std::string>& components);

/// The run's weights with `changes` applied.
Weights merge_weights(const Weights& base, const Weights& changes);

/// cost_i = Σ_c w_c · component_{i,c}, summed in component order (the task's order)   (eq. 23)
Vec rescore_costs(const ComponentRun& run, const Weights& weights);

/// A box ∩ Euclidean ball {x : |x − centre| ≤ radius}: the local ε-ball of RSSGD as a constraint region.
class BallRegion final : public RegionConstraint {
 public:
  BallRegion(Vec centre, double radius);
  const Box& bounds() const override { return box_; }
  bool has_constraint() const override { return true; }
  double constraint(const Vec& x, Vec* grad) const override;  ///< radius² − |x − centre|²
  Mat seeds() const override;                                   ///< the centre

 private:
  Vec centre_;
  double radius_;
  Box box_;
};

/// −(J̃(θ) + κ r̃(θ)) with r̃ = the critic's predictive std of the cost, as a function to maximize: the
/// NegativeConfidenceBound of select.hpp with the critic's arguments in rescore's order.
class RiskObjective final : public NegativeConfidenceBound {
 public:
  RiskObjective(const Surrogate& critic, double kappa, Index dim) : NegativeConfidenceBound(critic, dim, kappa) {}
};

struct OfflineSelection {
  double kappa = 0;
  Vec unit;          ///< selected θ, unit cube
  Vec theta;         ///< user units
  double mean = 0;   ///< J̃ at the selection
  double std = 0;    ///< r̃ at the selection
  /// J̃ more than 2 r̃ below every local cost, or the latent std over half the signal std: J̃ and r̃ there are the
  /// model's extrapolation (the same flags as `varbo select`).
  bool below_observed = false;
  bool far_from_data = false;
};

struct OfflineSelectionSettings {
  ResolvedComponent critic;     ///< local model
  ResolvedComponent optimizer;  ///< maximizer of −(J̃ + κ r̃) over the ball
  double radius = 0.2625;       ///< ε, unit cube
  Index min_points = 3;
  std::uint64_t seed = 1;
};

/// The critic and local data an offline selection used.
struct LocalModel {
  std::unique_ptr<Surrogate> critic;
  Dataset data;
  FitReport fit;
};

/// Fits the critic on the trials within ε of `centre` (unit cube) with costs `costs`, then minimizes
/// J̃ + κ r̃ over the ball for each κ. Throws NumericalError when no usable model results.
std::vector<OfflineSelection> select_offline(const ComponentRun& run, const Vec& costs, const Vec& centre,
                                             const std::vector<double>& kappas,
                                             const OfflineSelectionSettings& settings, const Registry& registry,
                                             LocalModel* model = nullptr);

/// What `varbo rescore` (and the dashboard's re-weighting) asks for.
struct OfflineRequest {
  Weights weight_changes;             ///< applied to the run's weights (parse_weight_list)
  std::vector<double> kappas{0.0, 2.0};
  double epsilon = -1;                ///< the ball's radius; ≤ 0: the run's (rssgd ε)
  std::optional<ResolvedComponent> critic;  ///< the local model; none: the run's
  std::optional<std::uint64_t> seed;        ///< none: the run's
};

struct OfflineAnswer {
  Weights weights;                    ///< the run's weights with the changes applied
  Vec costs;                          ///< every successful trial re-scored (eq. 23)
  double mismatch = 0;                ///< max |recorded cost − Σ w·component| under the run's own weights
  bool follows_convention = true;     ///< mismatch within round-off: re-scored costs compare with recorded ones
  Vec learned;                        ///< the ball's centre, user units: summary's recommended θ, else its best
  bool learned_is_recommended = false;
  Vec centre;                         ///< the same in the unit cube
  OfflineSelectionSettings settings;  ///< as used
  LocalModel model;
  std::vector<OfflineSelection> selections;  ///< one per κ, in the request's order
};

/// Re-weights, fits the local model around the learned policy and selects for every κ: the offline part of
/// `varbo rescore`, shared with `varbo dashboard` so both give the same selections.
OfflineAnswer rescore_offline(const ComponentRun& run, const OfflineRequest& request, const Registry& registry);

/// Default settings from the run: the local model of the run's algorithm when it offers RunContinuation
/// (varbo/continuation.hpp: rssgd's critic and ε), else that of the first loaded algorithm that offers it.
OfflineSelectionSettings offline_settings_from(const ComponentRun& run, const Registry& registry);

/// Mean and std of the cost over `rollouts` fresh episodes of `theta` (user units), streams derived from `seed`.
struct PolicyStats {
  double mean = 0;
  double std = 0;
  Index failed = 0;
};
PolicyStats evaluate_policy(Task& task, const Vec& theta, Index rollouts, std::uint64_t seed);

/// Throws ConfigError, saying why, when `run` cannot be continued: no loaded algorithm offers RunContinuation, or
/// the task has no `weights:` option (the continuation evaluates new trials under the re-scored weights).
void check_continuable(const ComponentRun& run, const Registry& registry);

/// Writes `folder`/study.yaml (the run's resolved config with the new weights, initial_point = `start`,
/// budget `steps`, and the algorithm block of the continuing algorithm — the run's own when it offers
/// RunContinuation, else the first loaded one that does (rssgd) — at risk `kappa` with the re-scored trials as
/// history) and runs it.
RunSummary continue_run(const ComponentRun& run, const Weights& weights, const Vec& costs, const Vec& start,
                        double kappa, Index steps, const std::string& folder, std::uint64_t seed,
                        const Registry& registry);

/// The former name of continue_run (the built-in continuing algorithm is rssgd).
inline RunSummary continue_with_rssgd(const ComponentRun& run, const Weights& weights, const Vec& costs,
                                      const Vec& start, double kappa, Index steps, const std::string& folder,
                                      std::uint64_t seed, const Registry& registry) {
  return continue_run(run, weights, costs, start, kappa, steps, folder, seed, registry);
}

}  // namespace varbo
