#include "failure_aware.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "pending_exclusion.hpp"
#include "varbo/errors.hpp"
#include "varbo/log.hpp"
#include "varbo/option_set.hpp"

namespace varbo::bo {

namespace {
using Enabled = FailureModelSettings::Enabled;
const OptionSet<FailureModelSettings>& failure_model_set() {
  static const OptionSet<FailureModelSettings> set{
      opt::choice("enabled", &FailureModelSettings::enabled,
                  {{"auto", Enabled::Auto}, {"on", Enabled::On}, {"off", Enabled::Off}},
                  "weight the acquisition by P(success | θ) from a GP classifier of the trials: auto = from the "
                  "first failed trial on (a run without failures is unchanged), on = always, off = failed trials "
                  "are ignored"),
      opt::real("min_probability", &FailureModelSettings::min_probability,
                "never suggest a θ whose modelled probability of success is below this, or below 0.8 × the "
                "success rate where nothing is known if that is lower (a failed θ and its neighbourhood are excluded "
                "until successes nearby say success is likely there)")
          .at_least(0)
          .below(1),
      opt::choice("lengthscales", &FailureModelSettings::lengthscales, {"ard", "shared"},
                  "the classifier's lengthscales: the cost model's times a common factor and then one factor per "
                  "dimension, chosen by the Laplace evidence (ard: a failure boundary seen in one place extends "
                  "along the coordinates it does not depend on), or the common factor only (shared)"),
      opt::real("refine_min_probability", &FailureModelSettings::refine_min_probability,
                "θ with P(success) below this, or below the incumbent's own P(success) if that is lower, are "
                "excluded in bo's final refinement (refine_last) and, with incumbent_level: always, in every "
                "model-based trial: the search does not gamble on θ merely more likely to succeed than not where "
                "the incumbent is safe (beside a failure boundary the refinement otherwise sat on the P = "
                "min_probability contour, failing every other trial)")
          .at_least(0)
          .below(1),
      opt::choice("incumbent_level", &FailureModelSettings::incumbent_level, {"refinement", "always", "fixed"},
                  "where refine_min_probability's rule (P(success) at least min(refine_min_probability, the "
                  "incumbent's P)) applies: the final refinement only, or every model-based trial; fixed = every "
                  "model-based trial, outside the refinement at refine_min_probability itself (not lowered to the "
                  "incumbent's P)"),
      opt::boolean("streak_backoff", &FailureModelSettings::streak_backoff,
                   "with a region without attempts (box, confidence), each failed trial in a row halves the "
                   "probability of failure a model-based trial may take (its level of P(success) becomes "
                   "1 − (1 − level)/2^f after f failures in a row), so the level does not follow the incumbent's "
                   "falling P into the failures; a trust region's attempts end after failure_run failures instead"),
      opt::boolean("replace_design", &FailureModelSettings::replace_design,
                   "after the initial design, one replacement point per failed design point (where success is likely, "
                   "farthest from the design's successes), so the first cost model sees as many points as without "
                   "failures"),
      opt::real("stall_value", &FailureModelSettings::stall_value,
                "> 0: once a trial has failed, the region (trust_region) also counts a trial without improvement "
                "whose cost lies within this fraction of stall_scale of the attempt's best as a stall (converged in "
                "value), so an attempt hands over to a fresh start sooner; 0 = off")
          .at_least(0)
          .below(1),
      opt::choice("stall_scale", &FailureModelSettings::stall_scale, {"best", "range", "std", "recent"},
                  "the scale of stall_value: |the attempt's best| (best), the range max − min of the attempt's "
                  "costs (range) or their standard deviation (std), or the range of its last 2(d + 1) costs (recent)"),
      opt::boolean("stall_strict", &FailureModelSettings::stall_strict,
                   "only trials that do not improve the attempt's best at all are value stalls (the polishing of a "
                   "basin by tiny improvements is spared)"),
      opt::real("stall_incumbent", &FailureModelSettings::stall_incumbent,
                ">= 0: value stalls count only while the attempt's best lies more than this × stall_scale above "
                "the best cost of all the data (the attempt holding or approaching the incumbent is polished); "
                "-1 = always")
          .at_least(-1),
      opt::integer("stall_remaining", &FailureModelSettings::stall_remaining,
                   "> 0: value stalls count only while at least this many trials of the budget remain (a later cut "
                   "leaves a fresh start too few trials and ends the polishing of the attempt it cuts); 0 = always")
          .at_least(0),
      opt::boolean("stall_attempt", &FailureModelSettings::stall_attempt,
                   "value stalls count only while the trials left in the budget are at least as many as the current "
                   "attempt has used (design included): a fresh start gets at least the trials of the attempt it "
                   "replaces, whatever the budget and dimension"),
      opt::real("repeat_distance", &FailureModelSettings::repeat_distance,
                "> 0: once a trial has failed, an attempt whose acquisition proposes a θ within this distance "
                "(max-norm, unit cube) of a point it has already evaluated counts as converged and the region "
                "restarts afresh instead of repeating it; only while the cost model's noise is at its floor (a "
                "deterministic cost: a repeat teaches nothing; under noise it is a measurement); 0 = off")
          .at_least(0)
          .below(1),
      opt::boolean("boundary_restart", &FailureModelSettings::boundary_restart,
                   "once a trial has failed, an attempt whose best point is blocked by the failure boundary (the cost "
                   "model's descent from it reaches θ where failure is likely within boundary_reach while the modelled "
                   "cost still falls) restarts afresh, while a fresh start can still be followed up"),
      opt::real("boundary_reach", &FailureModelSettings::boundary_reach,
                "distance (max-norm, unit cube) from the attempt's best point within which boundary_restart looks for "
                "the failure boundary along the cost model's descent")
          .above(0)
          .at_most(1),
      opt::real("boundary_tabu", &FailureModelSettings::boundary_tabu,
                "with boundary_restart or blocked_tabu, later attempts (not the final refinement) do not search within "
                "this distance (max-norm, unit cube) of the best point of an attempt that ended blocked; 0 = they may")
          .at_least(0)
          .at_most(1),
      opt::choice("feasible_region", &FailureModelSettings::feasible_region, {"off", "failed", "limited", "both"},
                  "once a trial has failed, what the trust region counts as a trial without improvement besides its "
                  "own (TuRBO's failure counter, which shrinks it): each failed model-based trial (failed), each "
                  "model-based step whose point was limited by the probability of success (P(success) within "
                  "feasible_margin of the level it had to reach), even if it improved (limited), or both; off = "
                  "neither"),
      opt::choice("feasible_shrink", &FailureModelSettings::feasible_shrink, {"count", "halve"},
                  "how feasible_region's events shrink the trust region: as one failure each of its counter (count) "
                  "or one halving of its side each (halve)"),
      opt::real("feasible_margin", &FailureModelSettings::feasible_margin,
                "feasible_region: limited: a step is limited when its point's P(success) lies within this of the level "
                "it had to reach")
          .at_least(0)
          .at_most(1),
      opt::integer("feasible_after", &FailureModelSettings::feasible_after,
                   "feasible_region: failed or both: a failed trial counts only as the k-th or later of consecutive "
                   "failed trials of the attempt (1 = every failed trial)")
          .at_least(1),
      opt::real("attempt_memory", &FailureModelSettings::attempt_memory,
                "> 0: once a trial has failed, a fresh attempt's cost model also sees the earlier attempts' points "
                "farther than this (max-norm, unit cube) from every earlier attempt's best point; 0 = its own points "
                "only")
          .at_least(0)
          .at_most(1),
      opt::choice("boundary_jump", &FailureModelSettings::boundary_jump, {"off", "far", "edge"},
                  "once a trial has failed, an attempt whose best point is blocked by an observed failure ahead along "
                  "the cost model's descent (boundary_restart's test) probes once the far side of the failure zone "
                  "along that descent (far: the first point past it with P(success) above the exclusion threshold; "
                  "edge: also the box's face where the ray leaves the box with P(success) rising again); off = never"),
      opt::real("follow_probe", &FailureModelSettings::follow_probe,
                "> 0: once a trial has failed, a successful trial farther than follow_distance from the current "
                "attempt's best and every earlier attempt's best, costing at most the incumbent's cost + this × the "
                "range of the costs, becomes the centre of a new attempt (no new design) while the current attempt "
                "sits in a known basin; 0 = off")
          .at_least(0),
      opt::real("follow_distance", &FailureModelSettings::follow_distance,
                "follow_probe: how far (max-norm, unit cube) a probe must lie from the attempt's best and every earlier "
                "attempt's best to count as another basin")
          .above(0)
          .at_most(1),
      opt::real("follow_block", &FailureModelSettings::follow_block,
                "follow_probe: > 0: only while a failed trial lies within this (max-norm, unit cube) of the current "
                "attempt's best (the attempt is held at a failure boundary); 0 = whether or not")
          .at_least(0)
          .at_most(1),
      opt::boolean("follow_separated", &FailureModelSettings::follow_separated,
                   "follow_probe: only a probe separated from the attempt's best by failure (a failed trial within "
                   "follow_block of the segment between them, or P(success) below the exclusion threshold somewhere "
                   "on it); false = distance alone"),
      opt::integer("follow_points", &FailureModelSettings::follow_points,
                   "follow_probe: an attempt begun at a probe models its own points and the probe's this many nearest "
                   "successful points (the probe included; -1 = restart_points); 0 = every point but those within "
                   "follow_memory of an earlier attempt's best")
          .at_least(-1),
      opt::real("follow_memory", &FailureModelSettings::follow_memory,
                "follow_probe with follow_points: 0: an attempt begun at a probe models every successful point except "
                "those within this (max-norm, unit cube) of an earlier attempt's best; 0 = every point")
          .at_least(0)
          .at_most(1),
      opt::boolean("blocked_tabu", &FailureModelSettings::blocked_tabu,
                   "once a trial has failed, an attempt that ends with its best point blocked by the failure boundary "
                   "(boundary_restart's test) keeps later attempts boundary_tabu away from that point"),
      opt::boolean("global_probe", &FailureModelSettings::global_probe,
                   "once a trial has failed, a fresh start's first design point is the maximizer over the whole box of "
                   "the acquisition weighted by P(success) on a model of every successful trial, if that model is "
                   "confident of an improvement there (mean + 3 sd below the incumbent); if it improves on every "
                   "earlier trial, the attempt continues from it without the rest of its design"),
      opt::integer("probe_every", &FailureModelSettings::probe_every,
                   "once a trial has failed, every this many trials of an attempt past its design, the global probe "
                   "(global_probe's point: the model of every successful trial confident of an improvement there) is "
                   "taken instead of the attempt's own proposal if it lies farther than 0.15 (max-norm, unit cube) "
                   "from the attempt's best point: the attempt keeps to P(success) near the incumbent's, so the far "
                   "side of a failure region is otherwise never searched; -1 = d + 1, 0 = never")
          .at_least(-1),
      opt::integer("failure_run", &FailureModelSettings::failure_run,
                   "an attempt whose last this many model-based trials all failed ends (a fresh start; with "
                   "blocked_tabu later attempts keep off its best point if a failure blocks its descent), not one "
                   "fall after another until stop_after_failures ends the run; 0 = never")
          .at_least(0),
      opt::boolean("short_restarts", &FailureModelSettings::short_restarts,
                   "once a trial has failed, a fresh start's design has d + 1 points (at most restart_points): the "
                   "failures took trials from the budget and a failure region lengthens the way to a basin, so a later "
                   "attempt keeps them for its search; false = restart_points whether or not trials failed"),
      opt::integer("refine_last", &FailureModelSettings::refine_last,
                   "once a trial has failed, bo's final refinement (refine_last) takes at least this many trials: "
                   "failures cut attempts short, so the last one often reaches its basin late; -1 = 2(d + 1), 0 = "
                   "bo's refine_last unchanged")
          .at_least(-1),
      opt::boolean("refine_backoff", &FailureModelSettings::refine_backoff,
                   "each failed trial of bo's final refinement halves the probability of failure it accepts (its "
                   "level of P(success) becomes 1 - (1 - level)/2^f after f failures): the level is the incumbent's "
                   "own P, which failures beside the incumbent lower, and the refinement's points followed it into "
                   "the failures; false = the level as outside the refinement"),
      opt::boolean("refine_waits", &FailureModelSettings::refine_waits,
                   "once a trial has failed, the final refinement (failure_model.refine_last trials before the end) "
                   "waits while the current attempt, past its design and farther than 0.15 (max-norm, unit cube) "
                   "from the incumbent, would pass the incumbent within d + 1 trials at the pace of its last d + 1 "
                   "successes, until bo's own refine_last trials remain"),
      opt::real("length_max", &FailureModelSettings::length_max,
                "once a trial has failed, the trust region's side is at most this (unit cube; the region's own "
                "length_max, 1.6, makes its box the whole cube, where EI proposes the box's corners); 0 = the "
                "region's own limit; other regions (box, confidence) take no cap")
          .at_least(0),
      opt::boolean("refine_known", &FailureModelSettings::refine_known,
                   "once a trial has failed, a final refinement trial whose best point is a θ already evaluated, on a "
                   "cost the model treats as deterministic, takes the best new point of the attempts' acquisition "
                   "(EI) at the same level of P(success) instead; false = measure that θ again"),
      opt::choice("backoff_fallback", &FailureModelSettings::backoff_fallback, {"new", "incumbent"},
                  "where refine_backoff leaves no point of the final refinement's box at its level of P(success): "
                  "new = on a cost the model treats as deterministic, the attempts' acquisition's (EI's) best new "
                  "point of the whole box at that level (else the incumbent); incumbent = measure the incumbent again"),
      opt::boolean("fit_failures", &FailureModelSettings::fit_failures,
                   "the classifier's lengthscales and signal are chosen among those that put every failed θ (without "
                   "a success within 0.01, max-norm) below P(success) 0.5, by the Laplace evidence; without it the "
                   "evidence alone may explain a failure beside successes away as noise and suggest its θ again"),
      opt::choice("design_repair", &FailureModelSettings::design_repair, {"farthest", "nearest"},
                  "where a fresh start's design point with P(success) below the exclusion threshold moves: the likely "
                  "success farthest from the other design points and earlier minima, or the nearest likely success"),
  };
  return set;
}
}  // namespace

std::vector<OptionSpec> failure_model_options() { return failure_model_set().specs(); }

std::string failure_model_default_yaml() {
  std::vector<std::string> items;
  for (const auto& spec : failure_model_set().specs())
    if (!spec.default_yaml.empty()) items.push_back(spec.name + ": " + spec.default_yaml);
  return fmt::format("{{{}}}", fmt::join(items, ", "));
}

FailureModelSettings parse_failure_model(const Options& o, const Registry* registry) {
  if (!o.is_set("failure_model")) return FailureModelSettings{};
  const ConfigNode node = o.node("failure_model");
  if (!node.is_map())
    node.fail("expected a map: {enabled: auto|on|off, min_probability: p, lengthscales: ard|shared, "
              "refine_min_probability: p, streak_backoff: bool, replace_design: bool, stall_value: f, stall_scale: best|range|std|recent, "
              "stall_strict: bool, stall_incumbent: t, stall_remaining: n, stall_attempt: bool, "
              "repeat_distance: d, boundary_restart: bool, boundary_reach: r, boundary_tabu: r, "
              "feasible_region: off|failed|limited|both, feasible_shrink: count|halve, feasible_margin: m, "
              "feasible_after: k, attempt_memory: r, boundary_jump: off|far|edge, follow_probe: f, "
              "follow_distance: r, follow_block: r, follow_separated: bool, follow_points: n, "
              "follow_memory: r, blocked_tabu: bool, design_repair: farthest|nearest, global_probe: bool, probe_every: n, failure_run: n, short_restarts: bool, refine_last: n, refine_backoff: bool, refine_waits: bool, refine_known: bool, backoff_fallback: new|incumbent, length_max: L, fit_failures: bool}");
  const Options options = validate_options(node, failure_model_set().specs(), "failure_model", registry, {});
  FailureModelSettings s = failure_model_set().read(options);
  // Settings that cannot act, said once each (audit, session 49: `enabled: off` beside a min_probability, or
  // follow_distance without follow_probe, ran in silence).
  // Only values other than the defaults: a study's stored configuration (and config.resolved.yaml) names every
  // setting.
  const Options defaults = validate_options(ConfigNode::parse("{}", "<failure_model defaults>"),
                                            failure_model_set().specs(), "failure_model", registry, {});
  const YAML::Node now = options.resolved(), plain = defaults.resolved();
  const auto inert = [&](std::vector<std::string> keys, bool inactive, const std::string& because) {
    if (!inactive) return;
    std::vector<std::string> given;
    for (const auto& k : keys)
      if (options.given(k) && YAML::Dump(now[k]) != YAML::Dump(plain[k])) given.push_back(k);
    if (!given.empty())
      log_warn_once(fmt::format("{}: failure_model: {} {} no effect: {}", node.where(), fmt::join(given, ", "),
                                given.size() > 1 ? "have" : "has", because));
  };
  std::vector<std::string> all;
  for (const auto& spec : failure_model_set().specs())
    if (spec.name != "enabled") all.push_back(spec.name);
  inert(all, s.enabled == FailureModelSettings::Enabled::Off, "enabled: off ignores failed trials");
  inert({"feasible_shrink", "feasible_margin", "feasible_after"}, s.feasible_region == "off",
        "feasible_region is off");
  inert({"follow_distance", "follow_block", "follow_separated", "follow_points", "follow_memory"},
        s.follow_probe == 0, "follow_probe is 0 (off)");
  inert({"boundary_tabu"}, !s.blocked_tabu && !s.boundary_restart,
        "blocked_tabu and boundary_restart are both false");
  return s;
}

std::optional<Vec> nearest_likely_success(const std::function<double(const Vec&)>& probability, const Vec& x,
                                          double min_p, Rng& rng) {
  // Session 33: before, a fresh start's design point where failure is likely moved to the likely success farthest
  // from the design (design_repair: farthest, now the fallback), and so away from the failure region's faces —
  // where a basin cut by the region begins (Hartmann-6 with the slab 0.195 < x2 < 0.495 next to its minimiser at
  // x2 = 0.15: the design point that led the failure-free run there lay in the slab). The nearest likely success
  // keeps the design's coverage there.
  const Index dim = x.size();
  std::vector<Vec> directions;
  for (Index d = 0; d < dim; ++d)
    for (const double sign : {1.0, -1.0}) {
      Vec u = Vec::Zero(dim);
      u(d) = sign;
      directions.push_back(std::move(u));
    }
  for (Index i = 0; i < 2 * dim; ++i) {
    const Vec u = rng.uniform_vec(dim).array() * 2.0 - 1.0;
    if (u.lpNorm<Eigen::Infinity>() > 0) directions.push_back(u / u.lpNorm<Eigen::Infinity>());
  }
  std::optional<Vec> best;
  int best_steps = std::numeric_limits<int>::max();
  for (const Vec& u : directions)
    for (int step = 1; step < best_steps && step <= 100; ++step) {
      const Vec z = x + (0.01 * step) * u;
      if ((z.array() < 0.0).any() || (z.array() > 1.0).any()) break;
      if (probability(z) >= min_p) {
        best_steps = step;
        best = z;
        break;
      }
    }
  return best;
}

Vec cost_lengthscales(const Hyperparameters& hyperparameters, Index dim, double fallback) {
  Vec ell = Vec::Constant(dim, fallback);
  for (Index d = 0; d < dim; ++d) {
    // fmt, not "[" + to_string: GCC 12 -Wrestrict false positive.
    const std::string gp_name = fmt::format("lengthscale[{}]", d), vhgp_name = fmt::format("lengthscale_f[{}]", d);
    const auto names = [](const std::string& name, const std::string& key) {  // key itself or "terms[..].key"
      return name == key || (name.size() > key.size() && name.compare(name.size() - key.size(), key.size(), key) == 0 &&
                             name[name.size() - key.size() - 1] == '.');
    };
    bool found = false;
    for (const Hyperparameter& h : hyperparameters)
      if ((names(h.name, gp_name) || names(h.name, vhgp_name)) && std::isfinite(h.value) && h.value > 0) {
        ell(d) = h.value;
        found = true;
        break;
      }
    // An isotropic kernel's one length scale (se, matern52: `lengthscale`) holds for every coordinate.
    for (const Hyperparameter& h : hyperparameters)
      if (!found && (names(h.name, "lengthscale") || names(h.name, "lengthscale_f")) && std::isfinite(h.value) &&
          h.value > 0) {
        ell(d) = h.value;
        break;
      }
  }
  return ell.cwiseMax(0.01).cwiseMin(10.0);
}

double failure_utility(const Acquisition& base, const Mat& X) {
  double u = 0;
  for (Index i = 0; i < X.rows(); ++i) {
    const double v = base.evaluate(X.row(i).transpose(), nullptr);
    if (std::isfinite(v)) u = std::min(u, v);
  }
  return u;
}

bool FeasibilityWeightedAcquisition::in_tabu(const Vec& x) const {
  for (const Vec& c : tabu_)
    if ((x - c).lpNorm<Eigen::Infinity>() < tabu_radius_) return true;
  return false;
}

double FeasibilityWeightedAcquisition::evaluate(const Vec& x, Vec* grad) const {
  // boundary_tabu: below every excluded (≥ −1) and allowed point.
  if (const std::optional<double> v = excluded_ball_value(x, tabu_, tabu_radius_, 0.0, grad)) return *v;
  Vec dp;
  const double p = model_.probability(at_ ? at_(x) : x, grad ? &dp : nullptr);
  if (p < p_min_) {
    // Excluded: below every allowed point, rising towards the allowed set.
    if (grad) *grad = dp;
    return -(p_min_ - p);
  }
  Vec du;
  const double u = base_.evaluate(x, grad ? &du : nullptr);
  if (!weighted_) {
    if (grad) *grad = du;
    return u - u_fail_;
  }
  if (grad) *grad = p * du + (u - u_fail_) * dp;
  return p * (u - u_fail_);
}

std::string FeasibilityWeightedAcquisition::state() const {
  const auto& h = model_.hyper();
  const std::string per_dim =
      h.dim_factor.size() ? fmt::format(" (per dimension ×{})", fmt::join(h.dim_factor.data(), h.dim_factor.data() + h.dim_factor.size(), ", ")) : "";
  return fmt::format("{} | feasibility{}: u_fail {:.3g}, min P {:.3g}, lengthscale ×{:g}{}, signal std {:g}, prior mean {:.3g}",
                     base_.state(), weighted_ ? "" : " (exclusion only)", u_fail_, p_min_, h.lengthscale_factor, per_dim,
                     h.signal_std, model_.prior_mean());
}

}  // namespace varbo::bo
