#pragma once
// Failure-aware acquisition: the acquisition weighted by the probability that a trial succeeds, as in the
// unknown-constraint handling of Gelbart, Snoek & Adams 2014 ("Bayesian optimization with unknown constraints",
// eq. 2: EI × P(feasible)) and Gardner et al. 2014, used by BayesOpt and Ax.
//
// The weighting is the expected utility of a trial that fails with probability 1 − P and then yields the utility
// u_fail of a failure:  E[u] = P·u(x) + (1 − P)·u_fail = u_fail + P·(u(x) − u_fail).  Maximizing it is maximizing
// P·(u(x) − u_fail). For improvement-based utilities (EI, PI, ERI: u ≥ 0, and a failure improves nothing)
// u_fail = 0 and this is exactly EI × P. For utilities that can be negative (cb: u = −(μ + κσ)) the product
// u × P would *prefer* likely failures wherever u < 0; with u_fail = the lowest utility at the evaluated points
// (a failure is worth no more than the worst trial seen) the weight again only rewards a likely success. The
// rule used, u_fail = min(0, min_i u(x_i)), gives both cases without knowing which acquisition is plugged in.
//
// Points where P < min_probability are excluded: their value is −(min_probability − P) < 0, below every allowed
// point, with the gradient of P, so a local optimizer started there climbs out towards likely success.
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "feasibility_model.hpp"
#include "varbo/acquisition.hpp"
#include "varbo/options.hpp"

namespace varbo::bo {

struct FailureModelSettings {
  enum class Enabled { Auto, On, Off };
  Enabled enabled = Enabled::Auto;  ///< auto: on from the first failed trial
  double min_probability = 0.5;
  /// The classifier's lengthscales: "ard" = one per dimension by the Laplace evidence; "shared" = the cost
  /// model's times one common factor.
  std::string lengthscales = "ard";
  /// bo's final refinement (refine_last trials), and every model-based trial with incumbent_level "always",
  /// excludes θ with P(success) below this, or below the incumbent's P if that is lower (never below
  /// min_probability's threshold).
  double refine_min_probability = 0.8;
  /// Where the incumbent's level (above) applies: "refinement" only, or "always" (every model-based trial); "fixed"
  /// (session fail13, not the default): every model-based trial, outside the refinement at refine_min_probability
  /// itself, not lowered to the incumbent's P.
  std::string incumbent_level = "always";
  /// With a region without attempts (box, confidence; no failure_run to end a streak): each failed trial in a row
  /// halves the probability of failure a model-based trial may take (session 46).
  bool streak_backoff = true;
  /// Each failed point of the initial design is followed by a replacement where success is likely.
  bool replace_design = false;
  /// > 0: once a trial has failed, the region (trust_region) also counts a trial without a region success whose
  /// cost lies within stall_value × stall_scale of the attempt's best as a stall (converged in value, e.g. along a
  /// flat direction), so an attempt hands over to a fresh start sooner: the failures have taken part of the budget
  /// and of the design's information (docs/failures.md). 0 = off. value_stall.hpp: the rule.
  /// The default since session 19, {1e-3, recent, strict, stall_attempt}: it rescues Hartmann-6 runs whose best
  /// design point the failure region hides (80 seeds: 28 → 23 stuck, median regret 3.4e-4 → 6.6e-7, the
  /// failure-free run's). Session 18's form with the range of all the attempt's costs was ruinous on Rosenbrock-4
  /// with a failure slab (median 0.35 → 38): the far design costs of heavy-tailed problems made every
  /// non-improving trial a "stall"; the range of the last 2(d + 1) costs (recent) is not set by them (0.35).
  double stall_value = 1e-3;
  /// The scale of stall_value: "best" (|the attempt's best|), "range" (max − min of the attempt's costs), "std"
  /// (their standard deviation) or "recent" (the range of its last 2(d + 1) costs; offset-free, and not set by a
  /// few far costs).
  std::string stall_scale = "recent";
  /// Only trials that do not improve the attempt's best at all count as value stalls. Off by default since session
  /// 40, together with refine_last: an attempt creeping by tiny improvements (along a failure boundary, or down a
  /// flat valley) hands over sooner, and the longer final refinement polishes the basin it was in (docs/failures.md).
  bool stall_strict = false;
  /// ≥ 0: value stalls count only while the attempt's best is more than stall_incumbent × stall_scale above the
  /// incumbent of all the data; < 0 = always.
  double stall_incumbent = -1;
  /// > 0: value stalls count only while at least this many trials of the budget remain (a later cut leaves a
  /// fresh start too few trials to converge, and costs the polishing of the attempt it ends); 0 = always.
  int stall_remaining = 0;
  /// Value stalls count only while the trials left in the budget are at least as many as the current attempt has
  /// used (its design included): a fresh start then gets at least the trials the attempt it replaces had, on the
  /// problem's own scale (dimension, budget, how long an attempt takes to converge) instead of a fixed count.
  bool stall_attempt = true;
  /// > 0: once a trial has failed, an attempt whose acquisition proposes a θ within this distance (∞-norm, unit
  /// cube) of a point already evaluated in the attempt has converged (its search collapsed onto its own data, e.g.
  /// creeping along a failure boundary): the region restarts afresh at once instead of spending the trial on a
  /// repeat. Only while the cost model treats the cost as deterministic (its noise at a data point below 1e-5 of the
  /// costs' std, as lowest_mean_evaluated): under noise a repeat is a legitimate measurement. 0 = off (the
  /// default: 1e-9 helps Hartmann-3 with a ball at budget 50 but costs it precision at 100; docs/failures.md,
  /// session creep12).
  double repeat_distance = 0;
  /// Once a trial has failed, an attempt whose best point is blocked by the failure boundary — a failed trial lies
  /// within boundary_reach (∞-norm, unit cube) of it, ahead along the cost model's descent (within 60°), and the
  /// modelled cost just before that failure is lower than at the best point — restarts afresh (while the budget
  /// leaves a fresh start its design twice over plus the refinement), and later attempts keep boundary_tabu away
  /// from that point. false = off (the default: it rescues one Hartmann-3 run of 20 but cuts three Hartmann-6 runs
  /// in the global basin whose cost model points into the slab; docs/failures.md, session fail13).
  bool boundary_restart = false;
  double boundary_reach = 0.05;
  /// Later attempts (not the refinement) do not search within this distance (∞-norm) of a blocked attempt's best
  /// (boundary_restart, blocked_tabu; 0.05 until session 33).
  double boundary_tabu = 0.15;
  /// A failure-aware trust region (session fail14): once a trial has failed, the region also counts as trials without
  /// improvement (TuRBO's failure counter; feasible_shrink: halve = one halving of L each) every failed model-based
  /// trial ("failed"), every model-based step whose point's P(success) lay within feasible_margin of the level it had
  /// to reach — the acquisition's optimum pressed against the failure model — even if it improved ("limited"), or
  /// both. "off" = neither (the default).
  std::string feasible_region = "off";
  std::string feasible_shrink = "count";
  double feasible_margin = 0.02;
  /// feasible_region: failed/both: a failed trial counts only when it ends a run of at least this many consecutive
  /// failed trials of the attempt (1 = every failed trial).
  int feasible_after = 1;
  /// > 0: once a trial has failed, a fresh attempt's cost model also sees the earlier attempts' points farther than
  /// this (∞-norm, unit cube) from every earlier attempt's best point (TuRBO's fresh start sees its own points only).
  /// 0 = off (the default; session fail14).
  double attempt_memory = 0;
  /// Once a trial has failed, an attempt whose best point is blocked (boundary_restart's test) probes once, instead of
  /// its proposal, the far side of the failure zone along the cost model's descent (the first point past the zone
  /// with P(success) at least the exclusion threshold, if the descent's ray does not leave the box first).
  /// "off" (the default), "far", or "edge": as far, and where the ray leaves the box with P(success) rising again
  /// past the zone, the last point in the box.
  std::string boundary_jump = "off";
  /// > 0 (session fail15): once a trial has failed, a successful trial of the current attempt that lies farther than
  /// follow_distance (∞-norm, unit cube) from the attempt's best point and from every earlier attempt's best, and
  /// costs at most the incumbent's cost + follow_probe × the range of the costs, becomes the centre of a new attempt
  /// (a fresh start of the trust region without a new design) — while the current attempt sits in a known basin (it
  /// holds the incumbent or its best lies within follow_distance of an earlier attempt's best) and at least
  /// 2 × refine_last trials remain. 0 = off (the default).
  double follow_probe = 0;
  double follow_distance = 0.25;
  /// > 0: only while a failed trial lies within this distance (∞-norm) of the attempt's best point (the attempt is
  /// held at a failure boundary); 0 = whether or not.
  double follow_block = 0.05;
  /// Only a probe separated from the attempt's best by failure: a failed trial lies within follow_block of the segment
  /// between them (strictly between the ends), or the classifier's P(success) falls below the exclusion threshold
  /// somewhere on it (the other side of the failure region, not a farther stretch of the same valley); false =
  /// distance alone.
  bool follow_separated = true;
  /// The cost model of an attempt begun at a probe: its own points and the probe's follow_points nearest successful
  /// points (∞-norm, the probe included; -1 = a fresh start's design size), a model of the probe's surroundings as
  /// a design would give. follow_points: 0 = instead every successful point except those within follow_memory
  /// (∞-norm) of an earlier attempt's best point (the basin left), the probe always (0 = every point): with it the
  /// blocked side's costs set EI's reference and the acquisition around the probe was flat (Hartmann-3 seed 1).
  int follow_points = -1;
  double follow_memory = 0.1;
  /// Once a trial has failed, an attempt that ends (its region converged) with its best point blocked by the failure
  /// boundary (boundary_restart's test) is remembered: later attempts keep boundary_tabu away from that point.
  bool blocked_tabu = true;
  /// Where a fresh start's design point with P(success) below the exclusion threshold moves: "farthest" (the likely
  /// success farthest from the design's other points and the earlier minima) or "nearest" (the nearest likely success
  /// along 2d coordinate and 2d random directions: the design keeps its coverage next to the failure region, where a
  /// basin beside it begins).
  std::string design_repair = "nearest";
  /// Once a trial has failed, a fresh start's first design point is the maximizer over the whole box of the phase's
  /// acquisition, weighted by P(success), on a model of every successful trial, where that model is confident of an
  /// improvement (bo_global_probe.cpp): an attempt models only its own points, and an earlier attempt held at a
  /// failure boundary may already show where the costs fall beyond it (Hartmann-3 with a ball across its valley: 16
  /// → 11 stuck runs of 40; docs/failures.md, session 36). The default since session 36.
  bool global_probe = true;
  /// Once a trial has failed, every `probe_every` trials of an attempt past its design (-1 = d + 1; 0 = never) the
  /// same probe is tried during the attempt: the maximizer over the whole box of the acquisition weighted by P(success)
  /// on a model of every successful trial, taken only where that model is confident of an improvement and farther
  /// than kAnotherBasin from the attempt's best point (bo_global_probe.cpp). An attempt searches its trust
  /// region at P(success) ≥ min(refine_min_probability, the incumbent's P) (incumbent_level: always), so where a
  /// failure region lies between its basin and a better one, the far side, where P(success) is only the design's
  /// success rate, is never searched, however clearly the costs measured so far point there; the first attempt of
  /// Hartmann-3 with the ball crept along the ball's face for its whole budget (session 41, docs/failures.md).
  int probe_every = -1;
  /// Once a trial has failed, an attempt whose last `failure_run` model-based trials all failed ends: the region
  /// restarts afresh, and (blocked_tabu) later attempts keep boundary_tabu away from its best point if an observed
  /// failure blocks its descent; 0 = never. The default (6) since session 37: held-out regions' runs failed 10 trials
  /// in a row beside their incumbent and stop_after_failures ended them (docs/failures.md, item 9).
  int failure_run = 6;
  /// The classifier's hyperparameters must put every failed θ without a success within 0.01 below P(success) 0.5
  /// (among those, the evidence decides; if none do, the evidence alone): a failure is not explained away as label
  /// noise (session 37).
  bool fit_failures = false;
  /// Once a trial has failed, a fresh start's design has d + 1 points (at most bo's restart_points) instead of
  /// restart_points: failures take trials from the budget and a failure region lengthens the way to a basin, so a
  /// later attempt needs its trials for the way more than for a design of 2(d + 1) points. The default since session 38
  /// (Hartmann-6 with a box cutting x2 between the minimiser and the rest: 44 → 34 stuck runs of 80; docs/failures.md).
  bool short_restarts = true;
  /// Once a trial has failed, bo's final refinement (refine_last) takes at least this many trials; -1 = 2(d + 1).
  /// Failed trials cut attempts short, and a run whose last attempt reached the global basin late ends it
  /// unpolished with d + 1 refinement trials (session 40, docs/failures.md). 0 = bo's refine_last unchanged.
  int refine_last = -1;
  /// Each failed trial of bo's final refinement halves the probability of failure the refinement accepts: after f
  /// of them its level of P(success) is 1 − (1 − level)/2^f. The level is the incumbent's own P (incumbent_level),
  /// which every failure beside the incumbent lowers, so without this a refinement at a failure face proposed its
  /// points ever closer to the failures: 13 of 14 refinement trials failed on a Hartmann-6 ball region, for no gain
  /// (session 42, docs/failures.md, item 13). The default since session 42.
  bool refine_backoff = true;
  /// Once a trial has failed, the final refinement, due refine_last (2(d + 1)) trials before the end, waits while the
  /// current attempt, past its design and in another basin than the incumbent (kAnotherBasin away), would pass the
  /// incumbent within d + 1 trials at the pace of its last d + 1 successes, until bo's own refine_last trials remain:
  /// the extra refinement trials otherwise cut short a last attempt on its way into a better basin (session 42,
  /// docs/failures.md, item 13).
  bool refine_waits = true;
  /// Once a trial has failed, the trust region's side L is at most this (the region's own length_max is 1.6, TuRBO's
  /// L_max): a region grown past the unit cube makes the attempt's search global, and EI there proposes the box's
  /// corners, where the model knows least (Hartmann-6: 4–5 corner trials per run, none informative). On a robot
  /// that is a jump to an untried extreme after a fall; kept near the attempt's best, the trials polish the basin
  /// being found (session 43, docs/failures.md, item 14). 0 = the region's own limit.
  double length_max = 0.8;
  /// Once a trial has failed, a final refinement trial whose best point is a θ already evaluated, on a cost the model
  /// treats as deterministic (its noise negligible), takes the attempts' acquisition's (EI's) best new point at the
  /// same level of P(success) instead: the refinement's level passes through the incumbent, and where the model's
  /// descent there points at the failures the posterior mean's constrained minimum is the incumbent, measured again
  /// to no purpose (Hartmann-6, slab x6 > 0.7, seed 19: 7 of 8 refinement trials; session 44, docs/failures.md,
  /// item 15). false = measure it again.
  bool refine_known = true;
  /// Where the final refinement's backoff (refine_backoff) leaves no point of the refinement's box at its level of
  /// P(success): "new" = on a cost the model treats as deterministic, the attempts' acquisition's (EI's) best new
  /// point over the whole box at that level, if there is one; "incumbent" = the incumbent measured again (session
  /// 42's fallback; under noise always, where a repeat is a measurement). Hartmann-6, slab 0.52 < x3 < 0.82, seed 60:
  /// the incumbent 0.0035 from the slab's face was measured 9 times (session 45, docs/failures.md, item 16).
  std::string backoff_fallback = "new";
  /// Active for a run with `failures` failed trials so far.
  bool active(Index failures) const {
    return enabled == Enabled::On || (enabled == Enabled::Auto && failures > 0);
  }
};

/// The keys of `bo.failure_model` (one declaration: validation, defaults, --describe).
std::vector<OptionSpec> failure_model_options();
/// The defaults of `bo.failure_model` as one YAML flow map, `bo`'s declared default of the key: a study's
/// resolved configuration names every failure-model setting, so a later change of a default does not silently
/// change a resumed study.
std::string failure_model_default_yaml();
/// Reads `bo.failure_model` (a map, validated) or the defaults when absent.
FailureModelSettings parse_failure_model(const Options& bo_options, const Registry* registry);

/// The cost model's lengthscales in the unit cube ("lengthscale[d]" of gp, "lengthscale_f[d]" of vhgp; in a
/// composite kernel the first term that has one, e.g. "terms[0].lengthscale[d]"), clipped to [0.01, 10];
/// `fallback` for a dimension the surrogate does not name.
Vec cost_lengthscales(const Hyperparameters& hyperparameters, Index dim, double fallback = 0.2);

/// The nearest point to x (in the unit cube) where `probability` reaches min_p, searched along ±each coordinate and
/// 2d random directions (∞-norm 1) in steps of 0.01: bo's design_repair: nearest. nullopt when every direction leaves
/// the cube first.
std::optional<Vec> nearest_likely_success(const std::function<double(const Vec&)>& probability, const Vec& x,
                                          double min_p, Rng& rng);

/// u_fail = min(0, min_i u(x_i)) over the rows of X (see above).
double failure_utility(const Acquisition& base, const Mat& X);

/// α̃(x) = P(x)·(u(x) − u_fail) where P(x) ≥ min_probability, −(min_probability − P(x)) elsewhere; with
/// `weighted` false (exclusion only) u(x) − u_fail where P(x) ≥ min_probability: bo's final refinement around an
/// incumbent that succeeded, where weighting by P would pull the point away from a failure boundary next to the
/// minimizer and cost precision (Branin with failures: docs/defaults.md).
/// `base` must be prepared; both references must outlive this object.
class FeasibilityWeightedAcquisition final : public Acquisition {
 public:
  FeasibilityWeightedAcquisition(const Acquisition& base, const FeasibilityModel& model, double failure_utility,
                                 double min_probability, bool weighted = true)
      : base_(base), model_(model), u_fail_(failure_utility), p_min_(min_probability), weighted_(weighted) {}
  void prepare(const AcquisitionContext&) override {}  // the base is prepared by the caller
  double evaluate(const Vec& x, Vec* grad) const override;
  bool has_gradient() const override { return base_.has_gradient(); }
  std::string state() const override;
  /// θ within `radius` (∞-norm) of a centre score below every other point, rising outwards (-1 - (radius - d) /
  /// radius): bo's failure_model.boundary_restart keeps later attempts off the best points of attempts that ended
  /// blocked by the failure boundary.
  void set_tabu(std::vector<Vec> centres, double radius) {
    tabu_ = std::move(centres);
    tabu_radius_ = radius;
  }
  /// Whether x lies in the tabu zone.
  bool in_tabu(const Vec& x) const;
  /// P(success) judged at the point that would be evaluated (typed parameters: x rounded), its gradient passed
  /// straight through. At the raw x the maximizer sat between integers or categories where P passed, and bo's
  /// check of the rounded point then refused it: 22 of 26 trials of a typed run became random (red team, session 31).
  void set_evaluated_point(std::function<Vec(const Vec&)> at) { at_ = std::move(at); }

 private:
  std::function<Vec(const Vec&)> at_;
  std::vector<Vec> tabu_;
  double tabu_radius_ = 0;
  const Acquisition& base_;
  const FeasibilityModel& model_;
  double u_fail_;
  double p_min_;
  bool weighted_;
};

}  // namespace varbo::bo
