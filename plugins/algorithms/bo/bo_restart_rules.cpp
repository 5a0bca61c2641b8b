// When an attempt of a bo run ends early or its trust region is told more than the trial's cost: converged on a
// repeat, stalled on a known point, blocked at an observed failure boundary, failed trials forced on the region
// (docs/failures.md).
#include "bayesian_optimization.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "varbo/errors.hpp"
#include "varbo/log.hpp"
#include "varbo/option_set.hpp"
#include "varbo/space_wrappers.hpp"
#include "varbo/value_stall.hpp"

namespace varbo::bo {

void BayesianOptimization::force_region_failures(Index k) {
  // failure_model.feasible_region (docs/failures.md, session fail14): Hartmann-3 with a ball creeps along the ball's
  // edge with the trust region at its maximum size, every creep step (a small improvement at the level of P(success)
  // the incumbent allows) counting as a region success. Here the failed model-based trials and the steps limited by
  // P(success) count as trials without improvement, so the region shrinks and, collapsed, restarts afresh.
  const std::string& mode = failure_settings_.feasible_region;
  const Index from = region_counted_to_;
  region_counted_to_ = std::max(region_counted_to_, k);
  if (mode == "off" || refining_ || failed_.empty() || !failure_settings_.active(static_cast<Index>(failed_.size())))
    return;
  ComponentState* state = state_of(region_.get());
  if (!state) return;
  // The current attempt's model-based trials only (its design's failures are the design's).
  const Index attempt_from = fresh_starts_ > 0 ? fresh_trial_ + restart_points_ : design_.rows();
  const Index lo = std::max(from, attempt_from);
  const auto in_range = [&](Index t) { return t >= lo && t < k; };
  int events = 0;
  // feasible_after: k: a failed trial counts only as the k-th (or later) of consecutive failed trials of the attempt.
  const auto run_of_failures = [&](Index t) {
    Index n = 0;
    while (t - n >= attempt_from && std::find(failed_trials_.begin(), failed_trials_.end(), t - n) != failed_trials_.end()) ++n;
    return n;
  };
  if (mode == "failed" || mode == "both")
    for (const Index t : failed_trials_) events += in_range(t) && run_of_failures(t) >= failure_settings_.feasible_after;
  if (mode == "limited" || mode == "both")
    for (const Index t : limited_trials_)
      events += in_range(t) && (mode == "limited" ||
                                std::find(failed_trials_.begin(), failed_trials_.end(), t) == failed_trials_.end());
  if (events == 0) return;
  StateMap m = StateMap::parse(state->save_state(), "region state");
  if (!m.has("successes") || !m.has("failures")) return;  // not a trust region
  const char* key = failure_settings_.feasible_shrink == "halve" ? "forced_halvings" : "forced_failures";
  m.put_int(key, (m.has(key) ? m.integer(key) : 0) + events);
  state->restore_state(m.text());
  log_debug("bo: trial {}: {} failed or limited trial(s) count as trust region failures", k, events);
}

Index BayesianOptimization::failed_in_a_row(Index k) const {
  const Index attempt_from = fresh_starts_ > 0 ? fresh_trial_ + restart_points_ : design_.rows();
  Index n = 0;
  while (k - 1 - n >= attempt_from &&
         std::find(failed_trials_.begin(), failed_trials_.end(), k - 1 - n) != failed_trials_.end())
    ++n;
  return n;
}

bool BayesianOptimization::converged_on_repeat(Index k, const Vec& x, const Dataset& data, const Dataset& model_data,
                                               const ValueStall& rule, Rng& region_rng) {
  // failure_model.repeat_distance (docs/failures.md, session creep12): once a trial has failed, the acquisition
  // of an attempt creeping along a failure boundary collapsed onto the attempt's own points (Hartmann-3 with a
  // ball: 27 exact repeats of a successful θ in 10 of 20 runs with failures, none without). On a deterministic cost
  // a repeat teaches nothing: the attempt has converged and the region restarts afresh now.
  const double delta = failure_settings_.repeat_distance;
  if (!(delta > 0) || failed_.empty() || !failure_settings_.active(static_cast<Index>(failed_.size()))) return false;
  const Index from = std::min(fresh_from_, data.size());
  Index near = -1;
  double nearest = std::numeric_limits<double>::infinity();
  for (Index i = from; i < data.size(); ++i) {
    const double d = (data.X.row(i).transpose() - x).lpNorm<Eigen::Infinity>();
    if (d < nearest) nearest = d, near = i;
  }
  if (near < 0 || nearest > delta) return false;
  // Deterministic only (lowest_mean_evaluated's test): under noise a repeat is a measurement.
  const double noise_std = std::sqrt(surrogate_->predict(data.X.row(near).transpose(), false).noise_var());
  if (!treats_cost_as_deterministic(noise_std, model_data.y)) return false;
  if (!restart_on_known(data, near, rule, region_rng)) return false;
  log_debug("bo: trial {}: proposed θ at distance {:.3g} of trial point {} of the attempt", k, nearest, near);
  return true;
}

bool BayesianOptimization::restart_on_known(const Dataset& data, Index near, const ValueStall& rule,
                                            Rng& region_rng) {
  auto* fresh_region = dynamic_cast<FreshStartRegion*>(region_.get());
  auto* value_stall = dynamic_cast<ValueStallRegion*>(region_.get());
  ComponentState* state = state_of(region_.get());
  if (!fresh_region || !state) return false;
  // The region's own stall rule decides, on the repeat's known outcome (deterministic: the cost observed there):
  // fantasized repeats, each a trial without improvement that counts as a stall, until the region restarts.
  const std::string before = state->save_state();
  const int starts = fresh_region->fresh_starts();
  if (value_stall) {
    ValueStall all;
    all.fraction = std::numeric_limits<double>::max();  // every trial without improvement is a stall
    value_stall->set_value_stall(all);
  }
  Dataset fantasy = data;
  for (int j = 0; j < 8 && fresh_region->fresh_starts() == starts; ++j) {
    fantasy.X.conservativeResize(fantasy.X.rows() + 1, Eigen::NoChange);
    fantasy.y.conservativeResize(fantasy.y.size() + 1);
    fantasy.X.row(fantasy.X.rows() - 1) = data.X.row(near);
    fantasy.y(fantasy.y.size() - 1) = data.y(near);
    region_->update(surrogate_.get(), fantasy, region_rng);
  }
  if (value_stall) value_stall->set_value_stall(rule);
  if (fresh_region->fresh_starts() == starts) {
    state->restore_state(before);  // the region would not restart (e.g. refining): nothing changes
    return false;
  }
  // The restart belongs to the real data: the new attempt's points begin at this trial.
  StateMap m = StateMap::parse(state->save_state(), "region state");
  if (m.has("restart_at")) m.put_int("restart_at", static_cast<long long>(data.size()));
  if (m.has("seen")) m.put_int("seen", static_cast<long long>(data.size()));
  state->restore_state(m.text());
  return true;
}

bool BayesianOptimization::blocked_at_boundary(Index k, const Vec& x, const Dataset& data, double level) const {
  // failure_model.boundary_restart (docs/failures.md, session fail13): Hartmann-3 with a ball creeps along the
  // ball's edge (x1 0.86 → 0.734 in steps of 0.003–0.07, each a small improvement) towards a valley that continues
  // inside the ball, then repeats its best point. The attempt is blocked when a failed trial lies within
  // boundary_reach of its best point, ahead along the cost model's descent, with the modelled cost lower just before
  // that failure (a minimum in between would be an interior one, to be polished). `level` (the acquisition's
  // P(success) threshold) is only logged: a test on the classifier's contour fired on the way into the valley
  // (seed 1, trial 13: P falls slowly, 0.87 → 0.78 over 0.05), so the evidence is an observed failure.
  if (!failure_settings_.boundary_restart || failed_.empty() || !feasibility_on_ ||
      !failure_settings_.active(static_cast<Index>(failed_.size())))
    return false;
  // A fresh start gets its design, as many model trials again, and the refinement.
  if (budget_ <= 0 || budget_ - k < 2 * restart_points_ + refine_last_) return false;
  return blocked_direction(k, x, data, level).has_value();
}

std::optional<std::pair<Vec, double>> BayesianOptimization::blocked_direction(Index k, const Vec& x, const Dataset& data,
                                                                              double level) const {
  const Index from = std::min(fresh_from_, data.size());
  if (data.size() - from < 2) return std::nullopt;
  Index best = from;
  for (Index i = from; i < data.size(); ++i)
    if (data.y(i) < data.y(best)) best = i;
  const Vec b = data.X.row(best).transpose();
  const double reach = failure_settings_.boundary_reach;
  // The attempt is working at its best point (not probing far away).
  if ((x - b).lpNorm<Eigen::Infinity>() > reach) return std::nullopt;
  const Box unit = Box::unit(dim_);
  const auto mean = [&](const Vec& z) { return surrogate_->predict(z, false).mean; };
  Vec g(dim_);
  const double h = 1e-5;
  for (Index d = 0; d < dim_; ++d) {
    Vec up = b, down = b;
    up(d) = std::min(1.0, b(d) + h);
    down(d) = std::max(0.0, b(d) - h);
    g(d) = (mean(up) - mean(down)) / std::max(up(d) - down(d), 1e-300);
  }
  const double gn = g.lpNorm<Eigen::Infinity>();
  if (!(gn > 0) || !std::isfinite(gn)) return std::nullopt;
  const Vec dir = -g / gn;  // a step t moves the point by t in its largest coordinate (∞-norm)
  // A failed trial within reach of the best point, ahead along the descent (within 60° of it): the way down is
  // blocked by a failure actually observed, not only by the classifier's smooth extrapolation (whose P falls
  // slowly, so a contour test fired on the way into a valley; Hartmann-3 seed 1 at trial 13).
  double ahead = -1;
  for (const Vec& f : failed_) {
    const Vec v = f - b;
    const double along = v.dot(dir) / dir.norm();
    if (v.lpNorm<Eigen::Infinity>() <= reach && along > 0.5 * v.norm() && (ahead < 0 || along < ahead)) ahead = along;
  }
  if (ahead < 0) return std::nullopt;
  // The cost model is lower just before that failure than at the best point (a minimum in between, where the
  // model rises again before the failure, is an interior one: polish it).
  const double at_best = mean(b);
  const double previous = mean(unit.clamp(b + (0.8 * ahead / dir.norm()) * dir));
  if (!(previous < at_best)) return std::nullopt;
  log_debug("bo: trial {}: the attempt's best point (trial point {}, P(success) {:.3g}, level {:.3g}) is blocked: the "
            "cost model falls by {:.3g} along its descent up to a failed trial {:.3g} ahead", k, best,
            feasibility_->probability(b), level, at_best - previous, ahead);
  return std::make_pair(dir, ahead);
}

void BayesianOptimization::remember_if_blocked(Index k, const Dataset& data) {
  // failure_model.blocked_tabu (session 33): Branin with the slab x2 < 0.3 over two of its minimisers: the first
  // attempt converges on the slab's face above the covered one (cost 3.93; the minimum 0.398) and the fresh starts,
  // whose models see only their own points, come back to it. Cutting the attempt there (boundary_restart) also cuts
  // Hartmann-6 attempts still approaching a minimiser next to a failure face; an attempt that has ended costs nothing
  // to remember.
  if (!failure_settings_.blocked_tabu || failed_.empty() || !feasibility_on_ ||
      !failure_settings_.active(static_cast<Index>(failed_.size())) || data.size() <= fresh_from_)
    return;
  const Index best = attempt_best(data);
  const Vec b = data.X.row(best).transpose();
  if (blocked_direction(k, b, data, exclusion_threshold_)) {
    blocked_.push_back(b);
    log_info("bo: trial {}: the attempt ended blocked by the failure boundary; later attempts keep {} away from its "
             "best point", k, failure_settings_.boundary_tabu);
  }
}

Index BayesianOptimization::attempt_best(const Dataset& data) const {
  const Index from = std::min(fresh_from_, data.size());
  Index best = from;
  for (Index i = from; i < data.size(); ++i)
    if (data.y(i) < data.y(best)) best = i;
  // An attempt begun at a probe (follow_probe): the probe is one of its points.
  if (follow_anchor_ >= 0 && follow_anchor_ < from && (best >= data.size() || data.y(follow_anchor_) <= data.y(best)))
    best = follow_anchor_;
  return best;
}

}  // namespace varbo::bo
