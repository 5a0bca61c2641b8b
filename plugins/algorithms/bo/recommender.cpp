#include "recommender.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <optional>

#include "varbo/away_from_failures.hpp"
#include "varbo/space_wrappers.hpp"
#include "varbo/state.hpp"
#include "varbo/errors.hpp"
#include "varbo/log.hpp"

namespace varbo::bo {

const std::vector<std::string>& recommendation_rule_names() {
  static const std::vector<std::string> names = {"lowest_mean_evaluated", "lowest_mean_domain",
                                                 "lowest_bound_evaluated", "best_observed"};
  return names;
}

RecommendationRule recommendation_rule(const std::string& name) {
  const auto& n = recommendation_rule_names();
  for (std::size_t i = 0; i < n.size(); ++i)
    if (n[i] == name) return static_cast<RecommendationRule>(i);
  throw ConfigError("bo: unknown recommendation rule '" + name + "'");
}

Recommender::Recommender(RecommendationRule rule, double kappa, std::unique_ptr<Surrogate> model)
    : rule_(rule), kappa_(kappa), model_(std::move(model)) {}

namespace {
Index best_observed(const Dataset& data) {
  Index best = 0;
  data.y.minCoeff(&best);
  return best;
}

/// The evaluated points a recommendation may name: none at a θ where trials failed at least as often as they
/// succeeded. A gain observed once and failed three times at the very same θ (replicates, or `varbo fail --theta`)
/// was recommended by every evaluated-point rule, its one success the lowest cost (red team, session 31). Every
/// point when each one is such a θ (said once): something must be recommended.
Dataset mostly_successful(const Dataset& data, const Mat& failed) {
  if (failed.rows() == 0 || failed.cols() != data.dim()) return data;
  constexpr double kSamePoint = 1e-9;  // in the unit cube: the same θ up to its text's rounding
  const auto same = [&](const auto& a, const auto& b) { return (a - b).cwiseAbs().maxCoeff() <= kSamePoint; };
  // A θ is left out when it failed at least as often as it succeeded there. Not at its first failure: one random
  // failure (a cable glitch) of a θ measured five times at the best cost barred it, and the recommendation went to
  // a θ 2,500× worse without a word (red team, session 49).
  Dataset out = Dataset::empty(data.dim());
  Index best = 0;
  data.y.minCoeff(&best);
  bool best_left_out = false, kept_a_failed = false;
  for (Index i = 0; i < data.size(); ++i) {
    Index failures = 0, successes = 0;
    for (Index j = 0; j < failed.rows(); ++j) failures += same(failed.row(j), data.X.row(i)) ? 1 : 0;
    if (failures > 0)
      for (Index j = 0; j < data.size(); ++j) successes += same(data.X.row(j), data.X.row(i)) ? 1 : 0;
    if (failures == 0 || successes > failures) {
      out.add(data.X.row(i).transpose(), data.y(i));
      kept_a_failed = kept_a_failed || failures > 0;
    } else if (i == best) {
      best_left_out = true;
    }
  }
  if (best_left_out)
    log_warn_once("bo: the θ of the lowest cost measured failed there as often as it succeeded; it is not recommended "
                  "(trials.csv lists them)");
  else if (kept_a_failed)
    log_warn_once("bo: some measured θ also failed there (less often than they succeeded); they may be recommended "
                  "(trials.csv lists them)");
  if (out.size() > 0) return out;
  log_warn_once("bo: every evaluated θ failed at least as often as it succeeded; the recommendation is one of them");
  return data;
}

}  // namespace

// The evaluated point with the lowest posterior mean; points whose mean is within a tenth of the noise std
// of that lowest one are tied, and the tie goes to the lowest observed cost (when the model treats the cost as
// deterministic, the lowest observed cost outright: below). The model cannot order means
// closer than the noise it assumes: on a deterministic cost (the noise at its floor, 1e-6 of std(y)) the
// posterior mean at a data point is y_i − σ_n²·α_i, and that shift reordered near-equal points (Branin with
// the plain default: recommended 3.2e-8 against 1e-9 best observed, seeds 1–20; docs/defaults.md). A tenth of
// σ_n keeps the winner's curse of a noisy cost (picking the luckiest of tied draws) negligible.
bool treats_cost_as_deterministic(double noise_std, const Vec& y) {
  constexpr double kDeterministicNoise = 1e-5;
  if (y.size() < 2) return false;
  const double spread = std::sqrt((y.array() - y.mean()).square().sum() / static_cast<double>(y.size() - 1));
  return noise_std <= kDeterministicNoise * spread;
}

Index lowest_mean_evaluated(const Surrogate& model, const Dataset& data) {
  if (data.size() == 0) throw std::logic_error("lowest_mean_evaluated without data");
  // The mean at every point (the mean alone where the model offers it: this runs after every trial), the lowest
  // (first on ties, as find_incumbent) and its noise.
  Vec mean(data.size());
  Index inc = 0;
  for (Index i = 0; i < data.size(); ++i) {
    mean[i] = posterior_mean(model, data.X.row(i).transpose());
    if (!std::isfinite(mean[i])) {
      // No order among the means: `mean < NaN` never held, and trial 0 was recommended whatever its cost (red
      // team, session 26).
      log_warn_once("bo: the recommendation model predicts a non-finite mean at an evaluated θ; the lowest observed "
                    "cost is recommended instead");
      return best_observed(data);
    }
    if (mean[i] < mean[inc]) inc = i;
  }
  const double lowest = mean[inc];
  const double noise_std = std::sqrt(model.predict(data.X.row(inc).transpose(), false).noise_var());
  // A model whose noise is at most 1e-5 of the costs' spread treats the cost as deterministic: every
  // observation is then the cost itself (up to that noise), and the means at the data differ from the observations
  // only by misfit (μ_i − y_i = −σ_n²α_i) and rounding (cond(K + σ_n²I) ~ 1e16 at such a noise): with SE-ARD on
  // Branin the lowest mean fell on a point of regret 2.7e-5 when one of 5.4e-11 had been observed (docs/defaults.md,
  // "Why SE-ARD is weaker"). The lowest observed cost is then the recommendation; its winner's curse is at most the
  // noise.
  if (treats_cost_as_deterministic(noise_std, data.y)) return best_observed(data);
  const double tol = 0.1 * noise_std;
  Index best = inc;
  if (!(tol > 0) || !std::isfinite(tol)) return best;
  for (Index i = 0; i < data.size(); ++i)
    if (data.y(i) < data.y(best) && mean[i] <= lowest + tol) best = i;
  return best;
}

void take_fitted_hyperparameters(const Surrogate& fitted, Surrogate& target, Index n) {
  // Every hyperparameter but a constant mean, which follows the data it is conditioned on (setting it
  // would fix it, e.g. the gp's `mean`, at the mean of the previous N − 1 costs).
  Hyperparameters h;
  for (const Hyperparameter& p : fitted.hyperparameters())
    if (p.name != "mean") h.push_back(p);
  target.set_hyperparameters(h);
  // Per-point state (VHGP's variational log Λ) covers the points of the latest fit; a point added since
  // starts at the median of the others, a neutral value the conditioning (or refit) then uses.
  for (auto [name, value] : fitted.state()) {
    if (name != "log_lambda") continue;
    if (value.size() == 0) continue;
    if (value.size() != n) {
      Vec v(n);
      const Index keep = std::min(value.size(), n);
      Vec sorted = value;
      std::sort(sorted.begin(), sorted.end());
      v.setConstant(sorted[sorted.size() / 2]);
      v.head(keep) = value.head(keep);
      value = v;
    }
    target.set_state(name, value);
  }
}

bool Recommender::prepare_model(const Surrogate& fitted, const Dataset& data, Rng& rng, bool refit) {
  // A surrogate that reports its full-fit counter (the vhgp's "last_full_fit_n", `warm_final_refit`) continues
  // its own fit schedule for the final refit: the recommendation model starts from the run model's exact
  // snapshot, as one more fit of the run's model would (its full fit from scratch was 2–6 s of a vhgp study at
  // N = 100, d = 5; docs/noisy.md). Other surrogates (the gp) refit a fresh model from their hyperparameters.
  if (refit) {
    bool schedule = false;
    for (const auto& [name, value] : fitted.state()) schedule = schedule || name == "last_full_fit_n";
    const ComponentState* from = schedule ? state_of(&fitted) : nullptr;
    ComponentState* to = schedule ? state_of(model_.get()) : nullptr;
    if (from && to) {
      try {
        to->restore_state(from->save_state());
        const FitReport rep = model_->fit(data, rng);
        if (!rep.ok) log_warn("bo: recommendation model: {}", rep.report());
        return model_->ready() && rep.ok;
      } catch (const std::exception& e) {
        log_warn("bo: recommendation model from the run model's snapshot: {}; refitting from its hyperparameters",
                 e.what());
      }
    }
  }
  try {
    take_fitted_hyperparameters(fitted, *model_, data.size());
  } catch (const std::exception& e) {
    log_warn("bo: recommendation model: {}", e.what());
    return false;
  }
  const FitReport rep = refit ? model_->fit(data, rng) : model_->condition(data);
  if (!rep.ok) log_warn("bo: recommendation model: {}", rep.report());
  return model_->ready() && rep.ok;
}

namespace {
/// `inner` ∩ {P(success | x) ≥ level}: c(x) = min(inner's c(x), P(x) − level).
class LikelyToSucceed final : public RegionConstraint {
 public:
  LikelyToSucceed(const RegionConstraint& inner, const SuccessOdds& odds, double level)
      : inner_(inner), odds_(odds), level_(level) {}
  const Box& bounds() const override { return inner_.bounds(); }
  bool has_constraint() const override { return true; }
  double constraint(const Vec& x, Vec* grad) const override {
    Vec gp;
    const double c = odds_.probability(x, grad ? &gp : nullptr) - level_;
    if (!inner_.has_constraint()) {
      if (grad) *grad = gp;
      return c;
    }
    Vec gi;
    const double ci = inner_.constraint(x, grad ? &gi : nullptr);
    if (grad) *grad = ci < c ? gi : gp;
    return std::min(ci, c);
  }
  Mat seeds() const override { return inner_.seeds(); }

 private:
  const RegionConstraint& inner_;
  const SuccessOdds& odds_;
  double level_;
};
}  // namespace

Vec Recommender::recommend(const Surrogate* fitted, const Dataset& data, const Mat& failed,
                           const RegionConstraint& region, const Optimizer& optimizer, Rng& rng, bool refit,
                           const SuccessOdds& success) {
  if (data.size() == 0) throw std::logic_error("Recommender::recommend without data");
  if (cached_n_ == data.size() && cached_failed_ == failed.rows() && cached_refit_ == refit &&
      cached_.size() == data.dim())
    return cached_;
  const Dataset candidates = mostly_successful(data, failed);
  const Vec observed = candidates.X.row(best_observed(candidates)).transpose();
  ready_ = false;
  Vec out = observed;
  if (rule_ != RecommendationRule::BestObserved && data.size() >= 2) {
    if (fitted && fitted->ready()) {
      ready_ = prepare_model(*fitted, data, rng, refit);
    } else if (refit) {
      // The budget ended before the run fitted a model (e.g. all trials in the initial design): fit one now.
      const FitReport rep = model_->fit(data, rng);
      if (!rep.ok) log_warn("bo: recommendation model: {}", rep.report());
      ready_ = rep.ok && model_->ready();
    }
  }
  if (ready_) {
    switch (rule_) {
      case RecommendationRule::LowestMeanEvaluated:
        out = candidates.X.row(lowest_mean_evaluated(*model_, candidates)).transpose();
        break;
      case RecommendationRule::LowestBoundEvaluated:
        out = candidates.X.row(find_incumbent(*model_, candidates, kappa_).index).transpose();
        break;
      case RecommendationRule::LowestMeanDomain: {
        // Minimize the posterior mean over the search region, started at the evaluated points; the best
        // evaluated point is kept when the optimizer finds nothing lower (it never recommends worse than
        // the lowest-mean evaluated point under the model). With failed trials only near the successful ones
        // (AwayFromFailures): the mean where trials failed is the model's extrapolation, and the minimum was
        // recommended between two failures (red team, session 26: 0.81 where every trial beyond 0.7 failed).
        // The distance rule alone lets the minimum sit on its edge, which crosses a failure boundary where no failed
        // trial is close (a third of the way to the nearest failure, further beside it): with the failure model's
        // classifier the recommendation must also be as likely to succeed as the evaluated point it replaces, up to
        // refine_min_probability (red team, session 27: 0.708 recommended where every trial past 0.7 failed).
        std::optional<AwayFromFailures> away;
        if (failed.rows() > 0 && failed.cols() == data.dim()) away.emplace(region, data.X, failed);
        const Vec at_data = candidates.X.row(find_incumbent(*model_, candidates, 0.0).index).transpose();
        std::optional<LikelyToSucceed> likely;
        if (away && success)
          likely.emplace(*away, success, std::min(success.cap, success.probability(at_data, nullptr)));
        const RegionConstraint& where = likely ? static_cast<const RegionConstraint&>(*likely)
                                        : away ? static_cast<const RegionConstraint&>(*away)
                                               : region;
        const Surrogate& m = *model_;
        // A surrogate without gradients is searched by values (an empty gradient stopped gradient optimizers).
        const bool gradients = m.predict(at_data, true).d_mean.size() == data.dim();
        FunctionRef neg_mean(
            data.dim(),
            [&m](const Vec& x, Vec* g) {
              const Prediction p = m.predict(x, g != nullptr);
              if (g) *g = -p.d_mean;
              return -p.mean;
            },
            gradients);
        const OptimizeResult r = optimizer.maximize(neg_mean, where, data.X, rng);
        out = at_data;
        if (r.x.size() == data.dim() && r.x.allFinite() && std::isfinite(r.value) &&
            -r.value < m.predict(at_data, false).mean) {
          const Vec x = Box::unit(data.dim()).clamp(r.x);
          // An optimizer that ignores constraints (ceres_lbfgs) may leave them: the evaluated point then.
          if (!away || where.constraint(x, nullptr) >= -1e-9) out = x;
        }
        break;
      }
      case RecommendationRule::BestObserved: break;
    }
  }
  cached_n_ = data.size();
  cached_failed_ = failed.rows();
  cached_refit_ = refit;
  cached_ = out;
  return out;
}

void Recommender::wrap_model(const SharedSpace& space) { model_ = respect_types(std::move(model_), space); }

}  // namespace varbo::bo
