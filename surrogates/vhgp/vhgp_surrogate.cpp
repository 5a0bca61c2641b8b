#include "vhgp_surrogate.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "budgeted_objective.hpp"
#include "homoscedastic_init.hpp"
#include "varbo/errors.hpp"
#include "varbo/log.hpp"
#include "varbo/restarts.hpp"

namespace varbo::vhgp {

namespace {

const double kLogHalf = std::log(0.5);

/// One restart's outcome, written only by its own task (deterministic reduction in index order).
struct RestartResult {
  bool ok = false;
  double objective = -std::numeric_limits<double>::infinity();
  Vec x;
};

bool parse_indexed(const std::string& name, const std::string& base, Index dim, Index& index) {
  if (name == base) {
    index = -1;  // all dimensions
    return true;
  }
  if (name.size() < base.size() + 3 || name.compare(0, base.size() + 1, base + "[") != 0 || name.back() != ']')
    return false;
  const std::string digits = name.substr(base.size() + 1, name.size() - base.size() - 2);
  if (digits.empty() || digits.find_first_not_of("0123456789") != std::string::npos) return false;
  index = std::stol(digits);
  return index < dim;
}

}  // namespace

VhgpSurrogate::VhgpSurrogate(Index dim, VhgpConfig config, std::shared_ptr<const Optimizer> fit_optimizer)
    : dim_(dim), config_(std::move(config)), optimizer_(std::move(fit_optimizer)) {
  if (dim_ < 1) throw ConfigError("vhgp: the problem dimension must be at least 1");
  if (config_.restarts < 1) config_.restarts = 1;
}

VhgpSurrogate::Scaling VhgpSurrogate::scaling_for(const Vec& y) const {
  Scaling s;
  if (!config_.standardize || y.size() == 0) return s;
  s.mean = y.mean();
  const double var = y.size() > 1 ? (y.array() - s.mean).square().sum() / static_cast<double>(y.size() - 1) : 0.0;
  s.scale = (var > 1e-24 && std::isfinite(var)) ? std::sqrt(var) : 1.0;
  return s;
}

VhgpParams VhgpSurrogate::to_model(const CostParams& c, Index n, const Scaling& s) const {
  VhgpParams p;
  p.theta_f = c.theta_f;
  p.theta_f(dim_) -= std::log(s.scale);       // σ_f of standardized costs
  p.theta_g = c.theta_g;
  p.mu0 = c.mu0 - 2.0 * std::log(s.scale);    // log noise variance of standardized costs
  // Warm start: keep the previous log Λ and pad new points with log ½ (β = 0, μ_i = μ0 there).
  p.log_lambda = Vec::Constant(n, kLogHalf);
  const Index keep = std::min<Index>(n, c.log_lambda.size());
  p.log_lambda.head(keep) = c.log_lambda.head(keep);
  return p;
}

VhgpSurrogate::CostParams VhgpSurrogate::to_cost(const VhgpParams& p, const Scaling& s) const {
  CostParams c;
  c.theta_f = p.theta_f;
  c.theta_f(dim_) += std::log(s.scale);
  c.theta_g = p.theta_g;
  c.mu0 = p.mu0 + 2.0 * std::log(s.scale);
  c.log_lambda = p.log_lambda;
  return c;
}

VhgpSurrogate::CostParams VhgpSurrogate::defaults(const Scaling& s) const {
  CostParams c;
  c.theta_f = Vec::Constant(dim_ + 1, std::log(0.3));
  c.theta_f(dim_) = std::log(s.scale);
  c.theta_g = Vec::Constant(dim_ + 1, std::log(0.3));
  c.theta_g(dim_) = std::log(0.5);
  c.mu0 = std::log(0.1) + 2.0 * std::log(s.scale);
  return c;
}

FitReport VhgpSurrogate::condition_at(const Dataset& data, const VhgpParams& params, const Scaling& s,
                                      FitReport report) {
  const Vec ys = (data.y.array() - s.mean) / s.scale;
  const VhgpBound bound(data.X, ys, config_.kernels);
  BoundValue value;
  auto post = std::make_shared<VhgpPosterior>(VhgpPosterior::condition(bound, params, &value));
  if (!value.ok) {
    report.ok = false;
    report.message = "conditioning failed (" + value.error + "); " +
                     (posterior_ ? "kept the previous model" : "no model available");
    log_warn("vhgp: {}", report.message);
    return report;
  }
  posterior_ = std::move(post);
  posterior_data_ = data;
  posterior_params_ = params.pack();
  scaling_ = s;
  params_ = to_cost(params, s);
  // F in cost units: y = m + s·y_s changes log N(y|·) by −n log s; the KL and tr Σ terms are unit-free.
  bound_ = value.F - static_cast<double>(data.size()) * std::log(s.scale);
  report.ok = true;
  report.log_likelihood = bound_;
  report.log_prior = config_.prior.log_density(params, nullptr);
  report.objective = report.log_likelihood + report.log_prior;
  return report;
}

FitReport VhgpSurrogate::condition(const Dataset& data) {
  const auto t0 = std::chrono::steady_clock::now();
  FitReport report;
  if (data.size() == 0 || data.dim() != dim_) {
    report.ok = false;
    report.message = "no data (or wrong dimension) to condition on";
    log_warn("vhgp: {}", report.message);
    return report;
  }
  const Scaling s = scaling_for(data.y);
  const CostParams c = params_ ? *params_ : defaults(s);
  if (c.log_lambda.size() != 0 && c.log_lambda.size() != data.size())
    log_warn("vhgp: log_lambda has {} values for {} points; missing ones are set to log(1/2), extra ones dropped",
             c.log_lambda.size(), data.size());
  const VhgpParams model_params = to_model(c, data.size(), s);
  report = condition_at(data, model_params, s, report);
  // For inspection (`varbo fit --no-optimize`): ∂F at the given parameters, packed as
  // [∂F/∂log Λ ; ∂F/∂θ_f ; ∂F/∂θ_g ; ∂F/∂μ0], in model (standardized) units, without the hyperprior.
  bound_gradient_ = Vec();
  if (report.ok) {
    const VhgpBound bound(data.X, (data.y.array() - s.mean) / s.scale, config_.kernels);
    const BoundValue v = bound.evaluate(model_params, true);
    if (v.ok) bound_gradient_ = v.gradient.pack();
  }
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return report;
}

FitReport VhgpSurrogate::fit(const Dataset& data, Rng& rng) {
  const auto t0 = std::chrono::steady_clock::now();
  FitReport report;
  report.optimized = true;
  const Index n = data.size();
  if (n == 0 || data.dim() != dim_) {
    report.ok = false;
    report.message = "no data (or wrong dimension) to fit";
    log_warn("vhgp: {}", report.message);
    return report;
  }
  const Scaling s = scaling_for(data.y);
  const Vec ys = (data.y.array() - s.mean) / s.scale;
  const VhgpBound bound(data.X, ys, config_.kernels);
  const VhgpObjective objective(bound, config_.prior);
  const BoxRegion region(parameter_box(n, dim_));
  const Box& box = region.bounds();

  // One seed drawn from the caller's stream per fit; restart k then uses stream k of it, whatever the thread.
  const Rng base(rng.next());

  if (config_.fixed_hyperparameters) {
    // Hyperparameters as given (`hyperparameters:`) or the defaults; only the variational parameters log Λ
    // are optimized, from the previous Λ (new points at log ½).
    const VhgpParams fixed = to_model(params_ ? *params_ : defaults(s), n, s);
    const VhgpObjective lambda_objective(bound, config_.prior, fixed);
    const BoxRegion lambda_region(Box{box.lower.head(n), box.upper.head(n)});
    Rng r = base.stream(2, 0);
    VhgpParams best = fixed;
    try {
      const OptimizeResult w = optimizer_->maximize(lambda_objective, lambda_region, fixed.log_lambda.transpose(), r);
      if (w.x.size() == n && w.x.allFinite() && std::isfinite(lambda_objective.value(w.x, nullptr)))
        best.log_lambda = lambda_region.bounds().clamp(w.x);
    } catch (const std::exception& e) {
      log_debug("vhgp: log Lambda optimization failed: {}", e.what());
    }
    report.restarts = 1;
    report = condition_at(data, best, s, report);
    report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return report;
  }

  // Start values (vhgp.md §8): the previous solution (warm start), a homoscedastic-GP initialization, and
  // random perturbations of the latter. Between full fits (see `full_fit_growth`) only the warm start runs.
  // Below kAlwaysFullFit points a full fit is cheap and the hyperparameters still move a lot from point to point
  // (a warm-only fit there lost a 15-trial Branin smoke test); the saving matters at large N.
  constexpr Index kAlwaysFullFit = 20;
  const bool warm = config_.warm_start && params_;
  const bool full = !warm || n <= kAlwaysFullFit || config_.full_fit_growth <= 1.0 || last_full_fit_n_ == 0 ||
                    n < last_full_fit_n_ ||
                    static_cast<double>(n) >= config_.full_fit_growth * static_cast<double>(last_full_fit_n_);
  const bool select = config_.noise_model == NoiseModel::Auto;
  const bool heteroscedastic = config_.noise_model != NoiseModel::Homoscedastic;
  // The homoscedastic fit: the GP start of a full fit (vhgp.md §8) and, when the noise model is selected, the
  // nested model the heteroscedastic fit has to beat (then at every fit, warm-started: it is cheap).
  HomoscedasticFit homo;
  if (full || !heteroscedastic || select) {
    Rng init_rng = base.stream(0);
    Vec warm_homo;
    if (homoscedastic_.size() == dim_ + 2) {
      warm_homo = homoscedastic_;
      warm_homo.tail(2).array() -= std::log(s.scale);  // log σ_f and log σ_n of standardized costs
    }
    homo = fit_homoscedastic(data.X, ys, config_.kernels.f, config_.kernels.jitter, config_.prior, *optimizer_,
                             init_rng, warm_homo.size() > 0 ? &warm_homo : nullptr, !full);
  }
  std::vector<VhgpParams> starts;
  const std::optional<CostParams>& warm_source = heteroscedastic_ ? heteroscedastic_ : params_;
  if (warm && heteroscedastic) starts.push_back(to_model(*warm_source, n, s));
  Index n_restarts = heteroscedastic ? 1 : 0;
  if (full && heteroscedastic) {
    VhgpParams gp_start;
    gp_start.log_lambda = Vec::Constant(n, kLogHalf);
    gp_start.theta_f = homo.theta_f;
    gp_start.theta_g = Vec::Constant(dim_ + 1, 0.0);
    gp_start.theta_g.head(dim_) = homo.theta_f.head(dim_);
    gp_start.theta_g(dim_) = std::log(0.5);
    gp_start.mu0 = homo.log_noise_var;
    starts.push_back(gp_start);
    n_restarts = std::max<Index>(config_.restarts, 1);
    for (Index k = static_cast<Index>(starts.size()); k < n_restarts; ++k) {
      Rng r = base.stream(1, static_cast<std::uint64_t>(k));
      VhgpParams p = gp_start;
      for (Index d = 0; d < dim_; ++d) {
        p.theta_f(d) += 0.5 * r.normal();
        p.theta_g(d) = std::log(r.uniform(0.05, 1.0));
      }
      p.theta_f(dim_) += 0.3 * r.normal();
      p.theta_g(dim_) = std::log(r.uniform(0.2, 1.5));
      p.mu0 = gp_start.mu0 + r.normal();
      starts.push_back(p);
    }
  }
  starts.resize(static_cast<std::size_t>(n_restarts));

  // Stage 1: every start gets `restart_evaluations` evaluations (all of them to convergence when 0 or when
  // there are no more starts than finalists). Stage 2: the `finalists` best of stage 1 are optimized to
  // convergence. Most restarts of a fit end in the same optimum, so spending 60–200 evaluations on each was
  // the bulk of the fit time (README, benchmark).
  const Index n_final = std::min<Index>(std::max(config_.finalists, 1), static_cast<Index>(starts.size()));
  const bool staged = config_.restart_evaluations > 0 && static_cast<Index>(starts.size()) > n_final;
  auto optimize = [&](const Vec& start, Rng& r, bool budgeted, Index k, RestartResult& out) {
    try {
      Vec x0 = box.clamp(start);
      if (config_.lambda_warmup && !out.ok) {
        // Phase 1: log Λ alone, hyperparameters fixed (the authors' fixhyp = 2 phase).
        const VhgpParams fixed = VhgpParams::unpack(x0, n, dim_);
        const VhgpObjective lambda_objective(bound, config_.prior, fixed);
        const BoxRegion lambda_region(Box{box.lower.head(n), box.upper.head(n)});
        const OptimizeResult w =
            optimizer_->maximize(lambda_objective, lambda_region, fixed.log_lambda.transpose(), r);
        if (w.x.size() == n && w.x.allFinite() && std::isfinite(w.value)) x0.head(n) = w.x;
      }
      Vec x;
      if (budgeted) {
        const BudgetedObjective limited(objective, config_.restart_evaluations);
        const OptimizeResult res = optimizer_->maximize(limited, region, x0.transpose(), r);
        x = limited.best_x();
        log_debug("vhgp: restart {} (stage 1): objective {:.10g} after {} iterations: {}", k, limited.best_value(),
                  res.iterations, res.message);
      } else {
        const OptimizeResult res = optimizer_->maximize(objective, region, x0.transpose(), r);
        x = res.x;
        log_debug("vhgp: restart {}: {} iterations ({} evaluations): {}", k, res.iterations, res.evaluations,
                  res.message);
      }
      if (x.size() == objective.dim() && x.allFinite()) {
        // Re-evaluate: the reported value must be the objective at the returned point.
        const double v = objective.value(x, nullptr);
        log_debug("vhgp: restart {}: objective {:.10g}", k, v);
        // A converged restart that ended below its stage-1 point keeps the better one.
        if (std::isfinite(v) && (!out.ok || v >= out.objective)) {
          out.ok = true;
          out.objective = v;
          out.x = x;
        }
      }
    } catch (const std::exception& e) {
      log_debug("vhgp: restart {} failed: {}", k, e.what());
    }
  };

  // Stage 1 (or the only stage): start k on stream (2, k); stage 2 continues finalist k on stream (3, k).
  const auto score = [](const RestartResult& r) { return r.ok ? std::optional<double>(r.objective) : std::nullopt; };
  std::vector<RestartResult> results =
      run_restarts<RestartResult>(
          static_cast<Index>(starts.size()), [&](Index k) { return base.stream(2, static_cast<std::uint64_t>(k)); },
          [&](Index k, Rng& r) {
            RestartResult out;
            optimize(starts[static_cast<std::size_t>(k)].pack(), r, staged, k, out);
            return out;
          },
          score)
          .results;
  if (staged) {
    // The finalists in order of their stage-1 objective (ties: lower index), independent of the thread count.
    std::vector<Index> order;
    for (Index k = 0; k < static_cast<Index>(results.size()); ++k)
      if (results[static_cast<std::size_t>(k)].ok) order.push_back(k);
    std::stable_sort(order.begin(), order.end(), [&](Index a, Index b) {
      return results[static_cast<std::size_t>(a)].objective > results[static_cast<std::size_t>(b)].objective;
    });
    order.resize(std::min<std::size_t>(order.size(), static_cast<std::size_t>(n_final)));
    const auto finalist = [&](Index j) { return order[static_cast<std::size_t>(j)]; };
    const Restarts<RestartResult> final_run = run_restarts<RestartResult>(
        static_cast<Index>(order.size()),
        [&](Index j) { return base.stream(3, static_cast<std::uint64_t>(finalist(j))); },
        [&](Index j, Rng& r) {
          RestartResult out = results[static_cast<std::size_t>(finalist(j))];  // keeps its stage-1 point if better
          optimize(out.x, r, false, finalist(j), out);
          return out;
        },
        score);
    for (std::size_t j = 0; j < order.size(); ++j)
      results[static_cast<std::size_t>(order[j])] = final_run.results[j];
  }

  Index failed = 0;
  const Index best = best_restart(results, score, &failed);
  report.restarts_failed += static_cast<int>(failed);
  report.restarts = static_cast<int>(results.size());
  std::optional<VhgpParams> chosen;
  if (best >= 0) chosen = VhgpParams::unpack(results[static_cast<std::size_t>(best)].x, n, dim_);
  const std::optional<VhgpParams> heteroscedastic_fit = chosen;
  bool homoscedastic_chosen = false;
  if ((select || !heteroscedastic) && homo.ok) {
    // Model selection between nested models on the bound (a lower bound of the log evidence; the
    // constant-noise member's bound is its exact log marginal likelihood): the heteroscedastic fit must
    // beat it by the BIC penalty ½(D+1) log N of g's extra hyperparameters. Without it, noise-free and
    // homoscedastic data got a noise process that fitted the noise to a few points and floored the
    // posterior (docs/noisy.md).
    const VhgpParams member =
        homoscedastic_member(homoscedastic_coordinates(homo), chosen ? *chosen : to_model(defaults(s), n, s), n);
    const BoundValue fh = bound.evaluate(member, false);
    const double fv = chosen ? bound.evaluate(*chosen, false).F : -std::numeric_limits<double>::infinity();
    const double penalty = 0.5 * static_cast<double>(dim_ + 1) * std::log(static_cast<double>(n));
    if (fh.ok && (!heteroscedastic || !(fv > fh.F + penalty))) {
      chosen = member;
      homoscedastic_chosen = true;
    }
    if (select)
      log_debug("vhgp: noise model on {} points: {} (bound heteroscedastic {:.6g}, homoscedastic {:.6g}, penalty {:.3g})",
                n, homoscedastic_chosen ? "homoscedastic" : "heteroscedastic", fv, fh.ok ? fh.F : -std::numeric_limits<double>::infinity(), penalty);
  }
  if (!chosen) {
    report.ok = false;
    report.message = "every restart failed; " + std::string(posterior_ ? "kept the previous model" : "no model");
    log_warn("vhgp: fit on {} points: {}", n, report.message);
  } else {
    report = condition_at(data, *chosen, s, report);
    if (report.ok) {
      if (full) last_full_fit_n_ = n;
      homoscedastic_selected_ = homoscedastic_chosen;
      if (heteroscedastic_fit) heteroscedastic_ = to_cost(*heteroscedastic_fit, s);
      if (homo.ok) {
        homoscedastic_ = homoscedastic_coordinates(homo);
        homoscedastic_.tail(2).array() += std::log(s.scale);
      }
    }
    if (report.ok && report.restarts_failed > 0)
      report.message = std::to_string(report.restarts_failed) + " restart(s) failed and were skipped";
    if (report.ok && select)
      report.message += std::string(report.message.empty() ? "" : "; ") +
                        (homoscedastic_chosen ? "homoscedastic noise selected" : "heteroscedastic noise selected");
  }
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return report;
}

VhgpParams VhgpSurrogate::homoscedastic_member(const Vec& x, const VhgpParams& like, Index n) const {
  VhgpParams p;
  p.theta_f = x.head(dim_ + 1);
  p.theta_g = like.theta_g;
  p.theta_g(dim_) = parameter_box(n, dim_).lower(n + 2 * dim_ + 1);  // σ_g at its lower bound: g ≡ μ0
  p.mu0 = 2.0 * x(dim_ + 1);
  p.log_lambda = Vec::Constant(n, kLogHalf);  // β = Λ − ½ = 0: every μ_i = μ0
  return p;
}

LatentPrediction VhgpSurrogate::predict_latent(const Vec& x, bool with_gradient) const {
  if (!posterior_) throw std::logic_error("vhgp: predict before fit/condition");
  return posterior_->predict(x, with_gradient);
}

Prediction VhgpSurrogate::predict(const Vec& x, bool with_gradient) const {
  const LatentPrediction l = predict_latent(x, with_gradient);
  const double s = scaling_.scale, s2 = s * s, log_s2 = 2.0 * std::log(s);
  Prediction p;
  p.mean = scaling_.mean + s * l.a;
  // Round-off can leave c*², σ*² slightly below 0 at training inputs; the true values are ≥ 0.
  const bool c2_clamped = l.c2 < 0, s2_clamped = l.s2 < 0;
  p.latent_var = s2 * std::max(l.c2, 0.0);
  p.log_noise_mean = l.mu + log_s2;
  p.log_noise_var = std::max(l.s2, 0.0);
  if (with_gradient) {
    p.d_mean = s * l.d_a;
    p.d_latent_var = c2_clamped ? Vec::Zero(dim_) : Vec(s2 * l.d_c2);
    p.d_log_noise_mean = l.d_mu;
    p.d_log_noise_var = s2_clamped ? Vec::Zero(dim_) : l.d_s2;
  }
  return p;
}

double VhgpSurrogate::signal_variance() const {
  const CostParams c = params_ ? *params_ : defaults(scaling_);
  return std::exp(2.0 * c.theta_f(dim_));
}

Hyperparameters VhgpSurrogate::hyperparameters() const {
  const CostParams c = params_ ? *params_ : defaults(scaling_);
  Hyperparameters h;
  for (Index d = 0; d < dim_; ++d) h.push_back({"lengthscale_f[" + std::to_string(d) + "]", std::exp(c.theta_f(d))});
  h.push_back({"signal_std_f", std::exp(c.theta_f(dim_))});
  for (Index d = 0; d < dim_; ++d) h.push_back({"lengthscale_g[" + std::to_string(d) + "]", std::exp(c.theta_g(d))});
  h.push_back({"signal_std_g", std::exp(c.theta_g(dim_))});
  h.push_back({"mu0", c.mu0});
  return h;
}

void VhgpSurrogate::set_hyperparameters(const Hyperparameters& values) {
  CostParams c = params_ ? *params_ : defaults(scaling_);
  for (const auto& h : values) {
    Index i = 0;
    auto positive = [&](double v) {
      if (!(v > 0) || !std::isfinite(v))
        throw ConfigError("vhgp: hyperparameter '" + h.name + "' must be a positive finite number, got " +
                          std::to_string(v));
      return std::log(v);
    };
    if (parse_indexed(h.name, "lengthscale_f", dim_, i)) {
      if (i < 0) c.theta_f.head(dim_).setConstant(positive(h.value));
      else c.theta_f(i) = positive(h.value);
    } else if (parse_indexed(h.name, "lengthscale_g", dim_, i)) {
      if (i < 0) c.theta_g.head(dim_).setConstant(positive(h.value));
      else c.theta_g(i) = positive(h.value);
    } else if (h.name == "signal_std_f") {
      c.theta_f(dim_) = positive(h.value);
    } else if (h.name == "signal_std_g") {
      c.theta_g(dim_) = positive(h.value);
    } else if (h.name == "mu0") {
      if (!std::isfinite(h.value)) throw ConfigError("vhgp: hyperparameter 'mu0' must be finite");
      c.mu0 = h.value;
    } else {
      throw ConfigError("vhgp: unknown hyperparameter '" + h.name + "'; expected lengthscale_f[0.." +
                        std::to_string(dim_ - 1) + "], signal_std_f, lengthscale_g[0.." + std::to_string(dim_ - 1) +
                        "], signal_std_g or mu0");
    }
  }
  params_ = c;
}

std::vector<std::pair<std::string, Vec>> VhgpSurrogate::state() const {
  std::vector<std::pair<std::string, Vec>> out = {{"log_lambda", params_ ? params_->log_lambda : Vec()}};
  if (bound_gradient_.size() > 0) out.emplace_back("bound_gradient", bound_gradient_);
  // y_s = (y − mean)/scale: relates the model-unit quantities (bound_gradient) to the costs (read-only).
  if (posterior_) out.emplace_back("standardization", (Vec(2) << scaling_.mean, scaling_.scale).finished());
  return out;
}

void VhgpSurrogate::set_state(const std::string& name, const Vec& value) {
  if (name == "standardization") return;  // recomputed from the data on every fit/condition
  if (name != "log_lambda") Surrogate::set_state(name, value);
  if (!value.allFinite()) throw ConfigError("vhgp: state 'log_lambda' must be finite");
  CostParams c = params_ ? *params_ : defaults(scaling_);
  c.log_lambda = value;
  params_ = c;
}

}  // namespace varbo::vhgp
