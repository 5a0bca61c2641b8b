// failure_model.follow_probe (docs/failures.md, session fail15): a successful probe in another basin, about as good
// as the incumbent, becomes the centre of a new attempt without a new design.
#include "bayesian_optimization.hpp"

#include <algorithm>
#include <limits>
#include <string>

#include "varbo/log.hpp"
#include "varbo/state.hpp"

namespace varbo::bo {

namespace {
double distance(const Vec& a, const Vec& b) { return (a - b).lpNorm<Eigen::Infinity>(); }
}  // namespace

Index BayesianOptimization::attempt_model_from(const Dataset& data) const {
  // The first attempt's model-based points follow the initial design's successes; a fresh start's follow its own
  // design's successes (the design's trials that did not fail); an attempt begun at a probe has no design.
  if (fresh_starts_ == 0) return std::min(design_told_ - design_failed_, data.size());
  if (follow_anchor_ >= 0) return std::min(fresh_from_, data.size());
  Index design_successes = 0;
  for (Index t = fresh_trial_; t < fresh_trial_ + restart_points_ && t < told_; ++t)
    design_successes += std::find(failed_trials_.begin(), failed_trials_.end(), t) == failed_trials_.end();
  return std::min(fresh_from_ + design_successes, data.size());
}

bool BayesianOptimization::separated_by_failure(const Vec& a, const Vec& b) const {
  // An observed failure beside the segment (its foot strictly between the ends, within follow_block of it), or the
  // classifier's P below the exclusion threshold on it. The observed test is needed: the middle of a failure region
  // is mostly unexplored, and there P is the prior success rate, above the threshold (Hartmann-3 seed 1: the far
  // probe at x1 = 0.007 behind the ball, the failure 0.009 from the best point at x1 = 0.734 on the way to it).
  const Vec d = b - a;
  const double dd = d.squaredNorm();
  if (dd > 0 && failure_settings_.follow_block > 0)
    for (const Vec& f : failed_) {
      const double t = (f - a).dot(d) / dd;
      if (t > 0 && t < 1 && (a + t * d - f).norm() <= failure_settings_.follow_block) return true;
    }
  for (int i = 1; i < 64; ++i) {
    const double t = i / 64.0;
    if (feasibility_->probability((1 - t) * a + t * b) < exclusion_threshold_) return true;
  }
  return false;
}

std::optional<Index> BayesianOptimization::probe_to_follow(Index k, const Dataset& data, bool refit) {
  // Hartmann-3 with a ball across the global valley (docs/failures.md, sessions fail13 and fail14): the first attempt
  // creeps along the ball's edge on the blocked side; in seed 20 a later attempt sampled the other side (trial 35:
  // −3.06 at x1 = 0.27, the blocked incumbent −3.67) but its trust region centred on its own best, the blocked
  // valley again, and the probe was never followed up. A restart rule comes too late at budget 50 (fail13), so
  // the lever is the probe itself.
  const FailureModelSettings& fs = failure_settings_;
  if (!(fs.follow_probe > 0) || failed_.empty() || !fs.active(static_cast<Index>(failed_.size()))) return std::nullopt;
  // The new attempt needs trials to descend before the final refinement; batch fantasies are not probes.
  if (budget_ <= 0 || budget_ - k < 2 * refine_last_ || data.size() != data_.size() || data.size() < 2)
    return std::nullopt;
  const Index b = attempt_best(data);
  if (b >= data.size()) return std::nullopt;
  const Vec xb = data.X.row(b).transpose();
  const std::vector<Vec> minima = earlier_minima();
  // The attempt sits in a known basin: it holds the incumbent with a point of its own search (a design's best
  // holding it is a fresh start that has just found a new basin, not one to leave), or its best lies next to an
  // earlier attempt's best (it went back to a basin already searched: seed 20's second attempt).
  const double lo = data.y.minCoeff(), hi = data.y.maxCoeff();
  bool known = data.y(b) <= lo && b >= attempt_model_from(data);
  for (const Vec& m : minima) known = known || distance(xb, m) <= fs.follow_distance;
  if (!known) return std::nullopt;
  // follow_block: the attempt is held at a failure boundary (a failed trial beside its best). Without this gate the
  // rule also left attempts polishing the global basin for a worse probe on the blocked side (Hartmann-3 seed 10:
  // 1.4e-07 → 0.0079; docs/failures.md, session fail15).
  if (fs.follow_block > 0) {
    bool held = false;
    for (const Vec& f : failed_) held = held || distance(f, xb) <= fs.follow_block;
    if (!held) return std::nullopt;
  }
  // The probe: the best successful point of the attempt (not the first attempt's initial design, which precedes
  // any basin) far from the attempt's best and from every earlier attempt's best, costing at most the incumbent +
  // follow_probe × the range of the costs (a scale the costs' offset does not change).
  const double ceiling = lo + fs.follow_probe * (hi - lo);
  const Index from = fresh_starts_ > 0 ? std::min(fresh_from_, data.size()) : attempt_model_from(data);
  // follow_separated: the classifier of this trial (fitted here, as the acquisition fits it below: a restored run
  // has no fitted classifier yet at this point). Without the test, a farther point of the same valley counted as
  // another basin (Hartmann-3 seed 17: x1 = 1.0 against the best at 0.736, both on the ball's blocked side).
  const bool separate = fs.follow_separated;
  bool classifier = false;
  std::optional<Index> chosen;
  for (Index i = from; i < data.size(); ++i) {
    if (i == b || data.y(i) > ceiling || (chosen && data.y(i) >= data.y(*chosen))) continue;
    const Vec x = data.X.row(i).transpose();
    bool far = distance(x, xb) > fs.follow_distance;
    for (const Vec& m : minima) far = far && distance(x, m) > fs.follow_distance;
    if (far && separate && !classifier) {
      classifier = true;
      if (!update_feasibility(k, refit)) return std::nullopt;
    }
    if (far && separate) far = separated_by_failure(x, xb);
    if (far) chosen = i;
  }
  if (chosen)
    log_debug("bo: trial {}: trial point {} (cost {:.6g}, {:.3g} from the attempt's best {:.6g}) is a probe in another "
              "basin within {:.3g} of the incumbent {:.6g}", k, *chosen, data.y(*chosen),
              distance(data.X.row(*chosen).transpose(), xb), data.y(b), ceiling - lo, lo);
  return chosen;
}

bool BayesianOptimization::follow_probe(Index k, Index probe, const Dataset& data, Rng& region_rng) {
  // The attempt ends as converged (its best point's known outcome, repeated until the trust region restarts
  // afresh), then the region's new attempt is anchored at the probe: its box is centred there and the probe is a
  // point of the attempt; no design is drawn, the trials go to the probe's basin at once.
  const Index b = attempt_best(data);
  if (!restart_on_known(data, b, ValueStall{}, region_rng)) return false;
  ComponentState* state = state_of(region_.get());
  StateMap m = StateMap::parse(state->save_state(), "region state");
  if (!m.has("restart_at")) return false;  // not a trust region: nothing to anchor (the restart stands)
  m.put_int("anchor", static_cast<long long>(probe));
  state->restore_state(m.text());
  begin_fresh_attempt(k, dynamic_cast<FreshStartRegion&>(*region_).fresh_starts(), data);
  fresh_trial_ = k - restart_points_;  // no design: the attempt's model-based trials begin now
  follow_anchor_ = probe;
  log_info("bo: trial {}: a new attempt ({}) begins at trial point {} (cost {:.6g}), a probe in another basin; no new "
           "design", k, fresh_starts_, probe, data.y(probe));
  return true;
}

}  // namespace varbo::bo
