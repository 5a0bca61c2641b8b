#pragma once
// Model-based optimization composed from plugins: initial design, surrogate, acquisition, region and
// acquisition optimizer, with optional phases (random / acquisition with ε-random exploration), as in the
// experiments of Kuindersma 2013 (section 5) and standard GP-BO (section 2).
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bo_settings.hpp"
#include "failure_aware.hpp"
#include "recommender.hpp"
#include "varbo/function.hpp"
#include "varbo/registry.hpp"
#include "varbo/search_space.hpp"
#include "varbo/state.hpp"
#include "varbo/value_stall.hpp"

namespace varbo::bo {

/// Two points of a run farther apart than this (max-norm, unit cube) are taken to lie in different basins: a probe
/// during an attempt (probe_every) must be this far from every attempt's best point, and the final refinement waits
/// (refine_waits) only for an attempt this far from the incumbent; the boundary_tabu distance.
inline constexpr double kAnotherBasin = 0.15;

/// A stretch of the run: `evaluations` trials chosen at random or by an acquisition (with probability ε at
/// random instead, Kuindersma 2013, section 3.4.2).
struct Phase {
  std::string name;
  Index evaluations = 0;  ///< 0 = until the budget is spent
  bool random = false;
  std::shared_ptr<Acquisition> acquisition;
  std::string acquisition_name;  ///< plugin/name, for messages about what it returns
  double epsilon = 0;
};

std::vector<OptionSpec> options();  ///< bo_options().specs()
/// The keys of one entry of `phases:` (bo_options.cpp).
const OptionSet<Phase>& phase_options();

class BayesianOptimization final : public Algorithm, public AlgorithmState, public SpaceAware {
 public:
  BayesianOptimization(const Options& options, const BuildContext& ctx);
  /// Typed parameters and constraints (docs/search_space.md), before the first ask().
  void set_search_space(SharedSpace space) override;
  std::vector<Suggestion> ask(Index q) override;
  void tell(const std::vector<Observation>& observations) override;
  /// Pending points enter the next batches as fantasies (batch_strategy) and shift the trial index.
  void set_pending(const std::vector<Vec>& pending) override;
  /// The θ to deploy, by the `recommendation` rule, on a model conditioned on every observation (refitted
  /// once the budget is spent); never the stale model of the last ask().
  std::optional<Vec> recommendation() const override;
  const Surrogate* model() const override { return model_ready_ ? surrogate_.get() : nullptr; }
  std::optional<ModelSnapshot> snapshot() const override;
  const Dataset& data() const { return data_; }
  /// Exact snapshots (bo_state.cpp): counters, the model snapshot and the states of the components that carry
  /// one; nullopt (replay) when the surrogate offers no ComponentState or points are pending.
  std::optional<std::string> save_state() const override;
  void restore_state(const std::string& state, const std::vector<Observation>& history) override;

 private:
  const Phase& phase_at(Index evaluation) const;
  Vec random_point(Rng& rng) const;
  /// n design points from the design sampler, inside the study's linear constraints (varbo/constrained_sampling.hpp).
  Mat design_sample(Index n, Rng& rng) const;
  /// The initial design: `initial_points_` points from kDesign's stream, the initial point first.
  /// Row `row` of the initial design as handed out (admissible for a typed space).
  Vec design_point(Index row) const;
  /// Which design rows an evaluated (successful or failed) or pending point already took (ask()).
  std::vector<bool> design_rows_taken() const;
  void draw_initial_design();
  /// The seeds and a copy of each moved by N(0, 0.01²) per coordinate that lies in `region`.
  Mat starts_near(const Mat& seeds, const RegionConstraint& region, Rng& rng) const;
  /// The start inside the region with the highest finite f (the first inside one if none is finite).
  std::optional<Vec> best_feasible(const DifferentiableFunction& f, const Mat& starts) const;
  Suggestion suggest(Index evaluation, const Dataset& data, bool refit);
  /// Trial k's point of the current fresh start's design (drawn anew from its own stream, so a restored run
  /// draws the same), or a random point where success is likely when failure is likely there.
  Vec fresh_design_point(Index k, bool refit);
  /// The region restarted afresh (its `fresh_starts` count) at trial k: a new attempt begins with the data so far.
  void begin_fresh_attempt(Index k, int fresh_starts, const Dataset& data);
  /// failure_model.repeat_distance: whether proposing x ends the attempt (the region restarts afresh); see the .cpp.
  bool converged_on_repeat(Index k, const Vec& x, const Dataset& data, const Dataset& model_data,
                           const ValueStall& rule, Rng& region_rng);
  /// Makes the region restart afresh by telling it repeats of data point `near` (a trial without improvement each,
  /// counted as a stall) until it does, on the real data; false (region unchanged) if it would not.
  bool restart_on_known(const Dataset& data, Index near, const ValueStall& rule, Rng& region_rng);
  /// failure_model.failure_run: the failed trials in a row that end trial k - 1, within the current attempt's
  /// model-based trials.
  Index failed_in_a_row(Index k) const;
  /// failure_model.boundary_restart: whether the attempt's best point is blocked by the failure boundary.
  bool blocked_at_boundary(Index k, const Vec& x, const Dataset& data, double level) const;
  /// failure_model.refine_known (bo_refine_known.cpp): a refinement proposal that is an evaluated θ of a deterministic
  /// cost is replaced by `acquisition`'s best new point at P(success) ≥ p_min; nullopt = keep the proposal.
  std::optional<Vec> refine_past_known(Index k, Acquisition& acquisition, const AcquisitionContext& actx, double p_min,
                                       bool model_gradients, const Mat& starts, const Vec& proposal,
                                       const Vec& model_y);
  /// failure_model.backoff_fallback: new (bo_refine_known.cpp): where the refinement's backoff leaves no point of its
  /// box at p_min, `acquisition`'s best new point of the whole box at P(success) ≥ p_min on a deterministic cost;
  /// nullopt = measure the incumbent again.
  std::optional<Vec> backoff_new_point(Index k, Acquisition& acquisition, const AcquisitionContext& actx, double p_min,
                                       bool model_gradients, const Vec& model_y);
  /// The best point of `acquisition` weighted by P(success) at level p_min, searched in `region` from `starts`:
  /// nullopt unless it is new (no evaluated θ within 1e-9) and reaches the level.
  std::optional<Vec> new_point_at_level(Acquisition& acquisition, const AcquisitionContext& actx, double p_min,
                                        bool model_gradients, const RegionConstraint& region, const Mat& starts,
                                        Rng& rng) const;
  /// The successful evaluated θ (the rows of data_), for nearest_within.
  std::vector<Vec> evaluated_thetas() const;
  /// Whether the model treats the cost as deterministic at evaluated θ number `at` (recommender.hpp's test).
  bool deterministic_at(Index at, const Vec& model_y) const;
  void remember_if_blocked(Index k, const Dataset& data);
  /// The test itself, without boundary_restart's gates: the cost model's descent from the attempt's best (∞-norm 1)
  /// and the distance along it to the blocking failed trial.
  std::optional<std::pair<Vec, double>> blocked_direction(Index k, const Vec& x, const Dataset& data,
                                                          double level) const;
  /// failure_model.follow_probe (bo_follow.cpp): the successful point to begin a new attempt at, if any.
  std::optional<Index> probe_to_follow(Index k, const Dataset& data, bool refit);
  /// Whether a failed trial lies beside the segment from a to b (within follow_block of a point strictly between the
  /// ends) or P(success) falls below the exclusion threshold somewhere on it (the fitted classifier; 64 steps).
  bool separated_by_failure(const Vec& a, const Vec& b) const;
  /// Ends the attempt and begins one anchored at data point `probe` (the trust region's anchor), without a design;
  /// false (nothing changed but, possibly, the region) if the region would not restart.
  bool follow_probe(Index k, Index probe, const Dataset& data, Rng& region_rng);
  /// failure_model.global_probe (bo_global_probe.cpp): the first point of a fresh start's design, if any.
  /// `role` names the trial in the log; with `away_from` (probe_every), only a point farther than
  /// kAnotherBasin from each of them where the model's sd is small (bo_global_probe.cpp).
  std::optional<Vec> global_probe(Index k, bool refit, const char* role, const std::vector<Vec>* away_from = nullptr);
  /// The trial of the latest global probe (-1: none); at the design's next trial, a successful probe that improved on
  /// every earlier trial ends the design: the attempt continues from it (follow_global_probe).
  Index probe_trial_ = -1;
  void follow_global_probe(Index k);
  /// failure_model.probe_every (bo_global_probe.cpp): at every probe_every-th trial of an attempt past its design, the
  /// global probe, if it lies away from every attempt's best point at a place the model knows.
  std::optional<Vec> attempt_probe(Index k, const Dataset& data, bool refit);
  std::unique_ptr<Surrogate> probe_model_;  ///< global_probe's model of every successful trial
  std::unique_ptr<RegionConstraint> whole_box_;  ///< global_probe's region: the box (with the space's constraints)
  /// The data index of the current attempt's first model-based point (after its design's successes).
  Index attempt_model_from(const Dataset& data) const;
  /// The data point the current attempt began at (follow_probe), -1 for an attempt with a design.
  Index follow_anchor_ = -1;
  /// failure_model.boundary_jump: the attempt best points from which the far side was probed.
  std::vector<Vec> jumped_;
  /// The best successful point of the current attempt (since the last fresh start).
  Index attempt_best(const Dataset& data) const;
  /// restart_design: away: of 16 designs, the one farthest from the best point of every earlier attempt.
  Mat design_away_from_minima(Rng& rng) const;
  /// The best point of every attempt before the latest fresh start.
  std::vector<Vec> earlier_minima() const;
  void fit_model(Index evaluation, const Dataset& data);
  /// The model a region with a model-based constraint (`region:constraint`: CRBO's confidence region) is updated
  /// with: the surrogate when `data` holds only observations, else observed_model_ conditioned on the observations
  /// only, with the surrogate's hyperparameters. Fantasies (points of a batch, points pending elsewhere) are not
  /// knowledge: the posterior variance they remove walked the confidence region past the data (σ_n/σ_f up to 0.75
  /// against γ = 0.6 in a batch of 16; red team, session 26).
  const Surrogate* region_model(Index evaluation, const Dataset& data);
  std::unique_ptr<Surrogate> observed_model_;  ///< only for regions that provide region:constraint
  std::pair<Index, Index> observed_model_key_{-1, -1};  ///< (observations, fits) it was conditioned for
  double lie(const Vec& x) const;
  /// Starts the final refinement of the incumbent of all the data (see BoSettings::refine_last).
  void begin_refinement(Index k, const Dataset& data);
  /// failure_model.refine_waits: whether the final refinement, due at trial k, waits for the current attempt, which
  /// lies in another basin than the incumbent and at the pace of its last d + 1 successes would pass it within d + 1
  /// trials (bo_attempts.cpp).
  bool refinement_waits(Index k, const Dataset& data) const;
  /// What the model is fitted to at this stage of the run: the refinement's data, the current attempt's points
  /// (since the last fresh start) or all of them; suggest() and a batch's first fit both use it.
  Dataset model_data_of(const Dataset& data) const;
  /// The final refinement's data (refine_model: attempt, basin or local).
  Dataset refinement_data(const Dataset& data) const;
  /// Failure awareness (failure_aware.hpp): fit the classifier on successes and failures (when `refit` or not
  /// yet fitted); true when the acquisition is to be weighted.
  bool update_feasibility(Index evaluation, bool refit);
  /// Fits `model` on every successful and failed trial told so far (with the design's success rate as the prior).
  bool fit_feasibility(FeasibilityModel& model) const;
  /// A random point; with the failure model on, the first of up to 64 draws with P(success) ≥ min_probability
  /// (else the likeliest draw), so random and ε-random trials avoid known failure regions too.
  Vec random_point_avoiding_failures(Rng& rng) const;
  /// The point a suggestion x (unit cube) becomes: clamped and, with typed parameters, admissible (integers and
  /// categories rounded). P(success) is judged there: the relaxation between two categories could pass where the
  /// category evaluated had failed every time.
  Vec evaluated_point(const Vec& x) const;
  /// Of 64 random points with P(success) ≥ min_p, the one farthest from the nearest of `away` (a design's
  /// replacement for a point where failure is likely or was seen: it keeps the design space-filling and away from
  /// earlier minima); the likeliest if none qualifies.
  Vec feasible_point_away(Rng& rng, const std::vector<Vec>& away, double min_p) const;

  BatchStrategy batch_strategy_ = BatchStrategy::KrigingBeliever;
  double pending_distance_ = 1e-3;  ///< bo's pending_distance (pending_exclusion.hpp)
  std::vector<Vec> pending_;
  bool said_no_gradients_ = false;
  double integer_exclusion_ = 0;  ///< half the widest integer cell of the unit cube (set_search_space)  ///< the surrogate's lack of gradients logged (once per run)
  bool prefitted_ = false;  ///< ask() already fitted on the real data (pending points present)

  Index dim_;
  Index budget_;
  Rng rng_;
  SharedSpace space_;  ///< typed parameters and constraints (null: a plain box)
  bool round_in_model_ = true;  ///< `discrete: transform` (else relax)
  std::unique_ptr<Sampler> design_sampler_;
  std::unique_ptr<Surrogate> surrogate_;
  std::string surrogate_name_;  ///< plugin/name, for messages about what it returns (component_outputs.hpp)
  std::string design_sampler_name_;  ///< plugin/name of initial_design, for messages about what it returns
  std::string region_name_;          ///< plugin/name of region, for messages about its bounds
  std::string optimizer_name_;  ///< the acquisition optimizer's plugin/name, likewise
  std::string refine_acquisition_name_;
  std::unique_ptr<RegionConstraint> region_;
  std::unique_ptr<Optimizer> optimizer_;
  std::unique_ptr<Optimizer> recommend_optimizer_;  ///< the recommender's own (see the constructor)
  std::vector<Phase> phases_;
  Index initial_points_ = 0;
  std::optional<Vec> initial_point_;  ///< BuildContext::initial_point: the design's first point
  Index restart_points_ = 0;  ///< a fresh start's design size now (short_restarts shortens it once a trial failed)
  Index configured_restart_points_ = 0;  ///< BoSettings::restart_points, resolved
  bool restart_away_ = false;  ///< restart_design: away
  bool replicate_design_ = false;  ///< the designs' last point repeats their first
  Index refit_every_ = 1;
  Mat design_;
  Dataset data_;             ///< successful observations
  Index told_ = 0;           ///< all observations, failed included
  std::vector<Vec> failed_;  ///< θ of failed observations (unit cube)
  Index design_told_ = 0, design_failed_ = 0;  ///< the first design_.rows() observations
  FailureModelSettings failure_settings_;
  std::unique_ptr<FeasibilityModel> feasibility_;
  bool feasibility_on_ = false;  ///< the classifier is fitted and weights the acquisition
  double exclusion_threshold_ = 0;  ///< θ with P(success) below it are never suggested
  Index fits_ = 0;
  bool model_ready_ = false;
  /// Fresh starts asked for by the region (varbo::FreshStartRegion): how many were seen, the trial at which the
  /// latest began (its design comes first) and the number of successful observations before it.
  int fresh_starts_ = 0;
  Index fresh_trial_ = 0, fresh_from_ = 0;
  Index refine_last_ = 0;  ///< see BoSettings::refine_last; lengthened once a trial failed (failure_model.refine_last)
  Index configured_refine_last_ = 0;  ///< BoSettings::refine_last, resolved
  bool refine_early_ = true;  ///< see BoSettings::refine_early
  std::unique_ptr<Acquisition> refine_acquisition_;
  bool refine_weighted_ = false;  ///< refine_feasibility: weight
  bool refine_attempt_model_ = false;  ///< refine_model: attempt or basin
  bool refine_basin_ = false;  ///< refine_model: basin (the attempt plus the other points near the incumbent)
  bool refine_local_ = false;  ///< refine_model: local (only the points near the incumbent, when there are enough)
  bool refining_ = false;
  std::vector<Index> attempt_starts_;  ///< successful observations before each fresh start
  /// failure_model.boundary_restart: the best points of attempts that ended blocked by the failure boundary; later
  /// attempts (not the refinement) do not search within boundary_reach of them.
  std::vector<Vec> blocked_;
  /// failure_model.feasible_region (session fail14): the trial indices of failed observations (from tell, so a restored
  /// run has them), of model-based steps limited by the probability of success, and the trial up to which the region
  /// has been told of them.
  std::vector<Index> failed_trials_;
  std::vector<Index> limited_trials_;
  Index region_counted_to_ = 0;
  /// Tells the trust region (its state's forced_failures / forced_halvings) of the failed and limited model-based
  /// trials of the current attempt since the last update, before the update at trial k.
  void force_region_failures(Index k);
  /// The final refinement's model (refine_model: attempt): observations [refine_lo_, refine_hi_) (the attempt
  /// that found the incumbent) and those from refine_from_ on (the refinement's own).
  Index refine_lo_ = 0, refine_hi_ = 0, refine_from_ = 0;  ///< the final refinement after fresh starts has begun
  /// The trial at which the final refinement began (failure_model.refine_backoff counts its failures from there).
  Index refine_trial_ = -1;
  ModelSnapshot snapshot_;
  std::unique_ptr<Recommender> recommender_;  ///< its own model: recommending changes no trial
};

}  // namespace varbo::bo
