// failure_model.global_probe (docs/failures.md, session 36): a fresh start's first design point, chosen by the
// acquisition on a model of every successful trial over the whole box.
//
// Why: after a fresh start an attempt models only its own points (TuRBO's restart, Eriksson 2019, section 2), so
// what the earlier attempts learned is used only to keep away from them. Where a failure region cuts a basin in
// two, the attempt held at the region's face on one side has often measured how the costs fall towards the other:
// Hartmann-3 with a ball across its valley, seed 1, the 34 successes before the first fresh start give a GP whose
// mean at the global minimiser behind the ball is −3.90 ± 0.01 (true −3.86; the incumbent −3.66), and expected
// improvement weighted by P(success) is largest there, while a space-filling design point lands in the small
// feasible part of that basin rarely. One trial of the design is spent on it, only where that model is confident of
// an improvement; if the probe improves on every trial, the attempt continues from it at once (follow_global_probe).
// Since session 41 the same probe is also tried every d + 1 trials of an attempt (failure_model.probe_every,
// attempt_probe below).
#include "bayesian_optimization.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "acquisition_scale.hpp"
#include "bo_streams.hpp"
#include "values_only.hpp"
#include "varbo/log.hpp"

namespace varbo::bo {

namespace {
/// A probe only where the model of every trial is confident of an improvement: its mean + this many standard
/// deviations below the incumbent (the probability of improvement ≥ 0.9987).
constexpr double kProbeConfidence = 3;
/// failure_model.probe_every: the model knows the probe's place: its sd at most this × the range of the successful
/// costs (behind Hartmann-3's ball, seed 1: 0.076 against a range of 3.6).
constexpr double kAttemptProbeSpread = 0.1;
}  // namespace

std::optional<Vec> BayesianOptimization::global_probe(Index k, bool refit, const char* role,
                                                      const std::vector<Vec>* away_from) {
  const FailureModelSettings& fs = failure_settings_;
  if (!probe_model_ || failed_.empty() || !fs.active(static_cast<Index>(failed_.size())) || data_.size() < 2)
    return std::nullopt;
  if (!update_feasibility(k, refit)) return std::nullopt;
  const auto uk = static_cast<std::uint64_t>(k);
  Rng frng = rng_.stream(kGlobalProbe, 3 * uk);
  const FitReport rep = probe_model_->fit(data_, frng);
  if (!probe_model_->ready()) {
    log_debug("bo: trial {}: no global probe (the model of every trial: {})", k, rep.report());
    return std::nullopt;
  }
  Acquisition& base = *phase_at(k).acquisition;
  Rng arng = rng_.stream(kGlobalProbe, 3 * uk + 1);
  AcquisitionContext actx{probe_model_.get(), &data_, k, &arng};
  base.prepare(actx);
  // The exclusion threshold only, not the incumbent's level of the attempts' trials (refine_min_probability): the
  // far side of a failure region is unexplored, where P(success) is the design's success rate (seed 1: 0.5), and
  // that level would exclude it. The weighting by P still prefers likely successes; it is one trial.
  Index best = 0;
  data_.y.minCoeff(&best);
  const double p_min = exclusion_threshold_;
  FeasibilityWeightedAcquisition weighted(base, *feasibility_, failure_utility(base, data_.X), p_min);
  if (space_) weighted.set_evaluated_point([this](const Vec& x) { return evaluated_point(x); });
  if (!blocked_.empty() && fs.boundary_tabu > 0) weighted.set_tabu(blocked_, fs.boundary_tabu);
  const Vec centre = Vec::Constant(dim_, 0.5);
  const bool gradients = probe_model_->predict(centre, true).d_mean.size() == dim_;
  const ValuesOnly values_only(weighted);
  const Acquisition& acquisition = gradients ? static_cast<const Acquisition&>(weighted) : values_only;
  AcquisitionFunction unscaled(acquisition, dim_);
  const double scale = acquisition_scale(*probe_model_);
  const ScaledFunction f(unscaled, scale);
  Rng orng = rng_.stream(kGlobalProbe, 3 * uk + 2);
  // Starts at every successful trial and a jittered copy (EI is flat at a data point), as for the attempts.
  const OptimizeResult res = optimizer_->maximize(f, *whole_box_, starts_near(data_.X, *whole_box_, orng), orng);
  if (!res.success || res.x.size() != dim_ || !res.x.allFinite()) {
    log_debug("bo: trial {}: no global probe (the acquisition optimizer: {})", k, res.message);
    return std::nullopt;
  }
  const Vec x = Box::unit(dim_).clamp(res.x);
  const double p = feasibility_->probability(evaluated_point(x));
  if (p < p_min || weighted.in_tabu(x)) return std::nullopt;
  const Prediction at = probe_model_->predict(x, false);
  // Only where that model is confident of an improvement. Measured against the alternatives (docs/failures.md,
  // session 36): where it extrapolates, its mean promises anything — Hartmann-6 with the slab x6 > 0.7, −0.7 ± 1.0
  // against the incumbent −3.2 (probes at such points made 18 of 80 runs worse by more than 2×, 9 better); Branin,
  // −94 ± 45 inside the failure disc against 0.398 (a cost of 17.5; such probes, even when required to promise 1 % of
  // the costs' range and to lie 0.25 from every earlier attempt's best, made 29 of 80 runs worse, 14 better). Behind
  // Hartmann-3's ball it was −3.90 ± 0.009 against −3.66.
  const double sd = std::sqrt(std::max(0.0, at.latent_var));
  if (!(at.mean + kProbeConfidence * sd < data_.y(best))) {
    log_debug("bo: trial {}: no global probe: the model of every successful trial predicts {:.6g} ± {:.3g} at the "
              "acquisition's best point, not confidently below the incumbent {:.6g}",
              k, at.mean, sd, data_.y(best));
    return std::nullopt;
  }
  if (away_from) {
    // An attempt's probe (probe_every) replaces a trial of an attempt at work, so it asks more than a fresh start's
    // design point (exploration either way): a place the model knows, its sd at most kAttemptProbeSpread × the range
    // of the successful costs (held-out box 0 of Hartmann-6, seed 45: −6.99 ± 0.77 promised against −3.20 and the
    // costs' range 3.2, −0.45 measured, and the run lost the global basin it reached without the probe), and another
    // basin than every attempt's best (seed 30 of held-out box 1: −3.0946 ± 0.0001 promised 0.01 from the incumbent,
    // at P(success) 0.5, a failure — polishing the incumbent is the final refinement's job).
    const double range = data_.y.maxCoeff() - data_.y.minCoeff();
    if (!(sd <= kAttemptProbeSpread * range)) {
      log_debug("bo: trial {}: no probe during the attempt: the model of every successful trial predicts {:.6g} ± "
                "{:.3g} there, an sd above {:g} × the costs' range {:.3g}", k, at.mean, sd, kAttemptProbeSpread, range);
      return std::nullopt;
    }
    for (const Vec& a : *away_from)
      if ((x - a).lpNorm<Eigen::Infinity>() <= kAnotherBasin) {
        log_debug("bo: trial {}: no probe during the attempt: the global probe lies within {:g} of an attempt's best "
                  "point", k, kAnotherBasin);
        return std::nullopt;
      }
  }
  log_info("bo: trial {}: {} is a global probe: the model of every successful trial predicts {:.6g} ± {:.3g} there "
           "(incumbent {:.6g}), P(success) {:.3g}",
           k, role, at.mean, sd, data_.y(best), p);
  return x;
}

void BayesianOptimization::follow_global_probe(Index k) {
  // The probe was the fresh design's first trial, it succeeded (its point is the attempt's first successful
  // observation) and it improved on every earlier trial: the rest of the design would only spread trials over a box
  // the earlier attempts have already searched, so the attempt continues from the probe at once: its trust region
  // centres there (the best point since the restart), and its model is the one that chose the probe, of every
  // successful trial (model_data_of). With follow_probe's model instead (the probe and its restart_points nearest
  // earlier points) Hartmann-3 seed 34 slid to the box face x1 = 0 (regret 0.0079; with every trial 4.4e-05).
  if (probe_trial_ < 0 || probe_trial_ != fresh_trial_ || k <= probe_trial_ || follow_anchor_ >= 0) return;
  if (std::find(failed_trials_.begin(), failed_trials_.end(), probe_trial_) != failed_trials_.end()) return;
  if (data_.size() <= fresh_from_ || fresh_from_ < 1) return;
  const double before = data_.y.head(fresh_from_).minCoeff();
  if (!(data_.y(fresh_from_) < before)) return;
  follow_anchor_ = fresh_from_;
  fresh_trial_ = k - restart_points_;  // no more design trials: the attempt's model-based trials begin now
  log_info("bo: trial {}: the global probe (trial {}) improved on every earlier trial ({:.6g} < {:.6g}): the attempt "
           "continues from it without the rest of its design", k, probe_trial_, data_.y(fresh_from_), before);
}

std::optional<Vec> BayesianOptimization::attempt_probe(Index k, const Dataset& data, bool refit) {
  // Why (session 41, docs/failures.md): an attempt keeps to P(success) ≥ min(refine_min_probability, the incumbent's
  // P) (incumbent_level: always), so the far side of a failure region — unexplored, where P(success) is the design's
  // success rate — is never in its search, and the global probe ran only at a fresh start, which an attempt creeping
  // along the failure region's face by small improvements does not reach. Hartmann-3 with the ball, seed 1: the first
  // attempt crept along the ball's face on the blocked side (−3.60 → −3.66) for its whole budget, while the model of
  // its successes predicted −4.03 ± 0.08 behind the ball (the probe there at trial 32: −3.851; regret 0.19 → 1.7e-06).
  // Every d + 1 trials by default, not every trial: as good on Hartmann-3 (7 stuck runs of 40 either way), at one
  // model fit and whole-box search per probe tried.
  const FailureModelSettings& fs = failure_settings_;
  const Index every = fs.probe_every < 0 ? dim_ + 1 : fs.probe_every;
  if (every == 0 || !feasibility_on_ || failed_.empty() || !fs.active(static_cast<Index>(failed_.size())) ||
      (k - fresh_trial_) % every != 0 || data.size() <= fresh_from_)
    return std::nullopt;
  std::vector<Vec> minima = earlier_minima();
  minima.push_back(data.X.row(attempt_best(data)).transpose());
  return global_probe(k, refit, "this trial of the attempt (probe_every)", &minima);
}

}  // namespace varbo::bo
