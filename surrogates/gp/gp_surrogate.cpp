#include "gp_surrogate.hpp"

#include <chrono>
#include <cmath>
#include <limits>

#include "varbo/config.hpp"
#include "varbo/errors.hpp"
#include "varbo/log.hpp"
#include "varbo/parallel.hpp"

namespace varbo::gp {

namespace {
constexpr double kLog2Pi = 1.8378770664093454836;

std::string lengthscale_name(Index i) { return "lengthscale[" + std::to_string(i) + "]"; }

Vec clamp_to(const Box& box, const Vec& p) { return p.cwiseMax(box.lower).cwiseMin(box.upper); }
}  // namespace

GpSurrogate::GpSurrogate(Index dim, GpSettings settings, std::shared_ptr<const Optimizer> fit_optimizer)
    : dim_(dim), settings_(settings), optimizer_(std::move(fit_optimizer)) {
  if (!optimizer_) throw std::invalid_argument("GpSurrogate: a fit optimizer is required");
  ensure_dim(dim);
}

void GpSurrogate::ensure_dim(Index d) {
  if (log_lengthscale_.size() == d) return;
  dim_ = d;
  // Start at the median of the lengthscale prior (whether or not the prior is used in the objective).
  log_lengthscale_ = Vec::Constant(d, settings_.priors.lengthscale.mean);
}

Box GpSurrogate::log_box(Index d) const {
  Box b;
  b.lower.resize(d + 2);
  b.upper.resize(d + 2);
  b.lower.head(d).setConstant(std::log(settings_.min_lengthscale));
  b.upper.head(d).setConstant(std::log(settings_.max_lengthscale));
  b.lower(d) = std::log(settings_.min_signal_std);
  b.upper(d) = std::log(settings_.max_signal_std);
  b.lower(d + 1) = std::log(settings_.min_noise_std);
  b.upper(d + 1) = std::log(settings_.max_noise_std);
  return b;
}

GpSurrogate::Standardization GpSurrogate::standardization(const Vec& y) {
  Standardization s;
  const Index n = y.size();
  if (n == 0) return s;
  s.shift = y.mean();
  const double var = n > 1 ? (y.array() - s.shift).square().sum() / static_cast<double>(n - 1) : 0.0;
  const double sd = std::sqrt(var);
  // Constant (or single) costs carry no scale: keep 1 so the model stays well defined.
  s.scale = (std::isfinite(sd) && sd > 1e-12 * std::max(1.0, std::abs(s.shift))) ? sd : 1.0;
  s.top = (y.maxCoeff() - s.shift) / s.scale;
  return s;
}

double GpSurrogate::mean_standardized(const Standardization& s) const {
  // The constant mean is not optimized: after standardization the data mean (0) is the natural choice
  // (a fitted constant is poorly identified against σ_f and drifts with long lengthscales); a user
  // value given through `hyperparameters: {mean: ...}` is kept fixed instead.
  if (mean_fixed_) return (mean_ - s.shift) / s.scale;
  return settings_.prior_mean == GpSettings::PriorMean::Max ? s.top : 0.0;
}

Vec GpSurrogate::log_params(double y_scale) const {
  const Index d = log_lengthscale_.size();
  Vec p(d + 2);
  p.head(d) = log_lengthscale_;
  const double log_scale = std::log(y_scale);
  p(d) = signal_known_ ? log_signal_std_ - log_scale : settings_.priors.signal_std.mean;
  p(d + 1) = noise_known_ ? log_noise_std_ - log_scale : settings_.priors.noise_std.mean;
  return p;
}

void GpSurrogate::store_natural(const Vec& p, const Standardization& s) {
  const Index d = p.size() - 2;
  log_lengthscale_ = p.head(d);
  log_signal_std_ = p(d) + std::log(s.scale);
  log_noise_std_ = p(d + 1) + std::log(s.scale);
  signal_known_ = noise_known_ = true;
  if (!mean_fixed_) mean_ = s.shift + s.scale * mean_standardized(s);
}

std::optional<GpSurrogate::Posterior> GpSurrogate::build(const Dataset& data, const Standardization& s,
                                                          const Vec& p) const {
  const Index d = data.dim(), n = data.size();
  Posterior post{kernels::ArdKernel(settings_.kernel, d), std::exp(2.0 * p(d + 1)), mean_standardized(s),
                 data.X, Vec(), Eigen::LLT<Mat>(), 0.0, 0.0, s, p};
  post.kernel.set_log_params(p.head(d + 1));
  if (n == 0) return post;
  const Vec r = (data.y.array() - s.shift).matrix() / s.scale - Vec::Constant(n, post.mean);
  Mat K = post.kernel.matrix(data.X);
  K.diagonal().array() += post.noise_var;
  RobustCholesky chol = robust_cholesky(K);
  if (!chol.ok) return std::nullopt;
  post.llt = std::move(chol.llt);
  post.jitter = chol.jitter;
  post.alpha = post.llt.solve(r);
  // Rasmussen & Williams eq. (5.8)
  post.log_likelihood = -0.5 * r.dot(post.alpha) - post.llt.matrixLLT().diagonal().array().log().sum() -
                        0.5 * static_cast<double>(n) * kLog2Pi;
  if (!post.alpha.allFinite() || !std::isfinite(post.log_likelihood)) return std::nullopt;
  return post;
}

FitReport GpSurrogate::report_for(const Posterior& post, const Vec& p) const {
  FitReport rep;
  // In cost units: y = shift + scale·y_std, so log p(y) = log p(y_std) − N log scale.
  const Index n = post.X.rows();
  rep.log_likelihood = post.log_likelihood - static_cast<double>(n) * std::log(post.stdz.scale);
  rep.log_prior = settings_.priors.log_density(p, nullptr);
  rep.objective = rep.log_likelihood + rep.log_prior;
  if (post.jitter > 0) rep.message = "jitter " + std::to_string(post.jitter) + " added to the diagonal";
  return rep;
}

FitReport GpSurrogate::condition(const Dataset& data) {
  const auto t0 = std::chrono::steady_clock::now();
  ensure_dim(data.dim());
  const Standardization s = standardization(data.y);
  const Vec p = log_params(s.scale);
  auto post = build(data, s, p);
  FitReport rep;
  if (post) {
    rep = report_for(*post, p);
    store_natural(p, s);
    posterior_ = std::move(post);
    data_ = data;
  } else {
    rep.ok = false;
    rep.message = "Cholesky failed even with jitter; the previous model is kept";
    log_warn("gp: {}", rep.message);
  }
  rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return rep;
}

FitReport GpSurrogate::fit(const Dataset& data, Rng& rng) {
  const auto t0 = std::chrono::steady_clock::now();
  ensure_dim(data.dim());
  if (data.size() == 0) return condition(data);
  const Index d = data.dim(), n = data.size();
  const Standardization s = standardization(data.y);
  const Box box = log_box(d);
  const Vec r = (data.y.array() - s.shift).matrix() / s.scale - Vec::Constant(n, mean_standardized(s));
  const LogPosterior objective(settings_.kernel, data.X, r, settings_.priors, box);
  const BoxRegion region(box);

  // Start 0: warm start from the current hyperparameters; the others drawn from the hyperpriors (or
  // uniformly in the log box when the priors are off), each from its own stream: thread-count independent.
  // Between full fits only the warm start runs (issue 13: most restarts of a refit on one more point end in
  // the optimum the warm start reaches); below kAlwaysFullFit points the hyperparameters still move a lot.
  constexpr Index kAlwaysFullFit = 20;
  const bool warm_known = signal_known_ && noise_known_ && posterior_.has_value();
  const bool full = !warm_known || n <= kAlwaysFullFit || settings_.full_fit_growth <= 1.0 || last_full_fit_n_ == 0 ||
                    n < last_full_fit_n_ ||
                    static_cast<double>(n) >= settings_.full_fit_growth * static_cast<double>(last_full_fit_n_);
  const Index restarts = full ? std::max(1, settings_.restarts) : 1;
  const std::uint64_t base = rng.next();
  std::vector<Rng> streams;
  Mat starts(restarts, d + 2);
  for (Index k = 0; k < restarts; ++k) {
    streams.push_back(rng.stream(base, static_cast<std::uint64_t>(k)));
    Vec p(d + 2);
    if (k == 0) {
      p = log_params(s.scale);
    } else {
      Rng& g = streams.back();
      const HyperPriors& pr = settings_.priors;
      for (Index j = 0; j < d + 2; ++j) {
        const LogNormalPrior& prior = j < d ? pr.lengthscale : (j == d ? pr.signal_std : pr.noise_std);
        p(j) = pr.enabled ? prior.mean + prior.sd * g.normal() : g.uniform(box.lower(j), box.upper(j));
      }
    }
    starts.row(k) = clamp_to(box, p).transpose();
  }

  std::vector<OptimizeResult> results(static_cast<std::size_t>(restarts));
  parallel_for(restarts, [&](Index k) {
    OptimizeResult& res = results[static_cast<std::size_t>(k)];
    try {
      res = optimizer_->maximize(objective, region, starts.row(k), streams[static_cast<std::size_t>(k)]);
      if (res.success && res.x.size() == d + 2 && res.x.allFinite()) {
        // The optimizer may ignore the box (ceres_lbfgs): clamp and score the point actually used.
        res.x = clamp_to(box, res.x);
        res.value = objective.value(res.x, nullptr);
        res.success = std::isfinite(res.value);
      } else {
        res.success = false;
      }
    } catch (const std::exception& e) {
      res.success = false;
      res.message = e.what();
    }
  });

  // Reduce in index order (ties keep the lower index).
  Index best = -1, failed = 0;
  for (Index k = 0; k < restarts; ++k) {
    const OptimizeResult& res = results[static_cast<std::size_t>(k)];
    if (!res.success) {
      ++failed;
      continue;
    }
    if (best < 0 || res.value > results[static_cast<std::size_t>(best)].value) best = k;
  }

  FitReport rep;
  std::optional<Posterior> post;
  Vec p;
  if (best >= 0) {
    p = results[static_cast<std::size_t>(best)].x;
    post = build(data, s, p);
  }
  if (!post && !full) {
    // The warm start alone failed: a full fit before giving up.
    last_full_fit_n_ = 0;
    return fit(data, rng);
  }
  if (post) {
    rep = report_for(*post, p);
    rep.optimized = true;
    store_natural(p, s);
    posterior_ = std::move(post);
    data_ = data;
    if (full) last_full_fit_n_ = n;
  } else {
    // Keep the last good hyperparameters; condition them on the new data when that still works.
    rep = condition(data);
    rep.ok = false;
    rep.message = "every restart failed; kept the previous hyperparameters" +
                  (rep.message.empty() ? std::string() : " (" + rep.message + ")");
    log_warn("gp: {}", rep.message);
  }
  rep.restarts = static_cast<int>(restarts);
  rep.restarts_failed = static_cast<int>(failed);
  rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return rep;
}

Prediction GpSurrogate::predict(const Vec& x, bool with_gradient) const {
  Prediction pr;
  const Index d = x.size();
  if (!posterior_ || posterior_->X.rows() == 0) {
    // Prior: the constant mean and σ_f² everywhere.
    pr.mean = mean_;
    pr.latent_var = signal_variance();
    const double log_sn = noise_known_ ? log_noise_std_ : settings_.priors.noise_std.mean;
    pr.log_noise_mean = 2.0 * log_sn;
    if (with_gradient) pr.d_mean = pr.d_latent_var = pr.d_log_noise_mean = pr.d_log_noise_var = Vec::Zero(d);
    return pr;
  }
  const Posterior& post = *posterior_;
  const double scale = post.stdz.scale;
  const Vec k = post.kernel.cross_vec(x, post.X);
  const Vec v = post.llt.matrixL().solve(k);
  // R&W eqs. (2.25)–(2.26), standardized, then mapped back to cost units.
  const double var_std = post.kernel.variance() - v.squaredNorm();
  pr.mean = post.stdz.shift + scale * (post.mean + k.dot(post.alpha));
  pr.latent_var = scale * scale * std::max(var_std, 0.0);
  pr.log_noise_mean = std::log(post.noise_var) + 2.0 * std::log(scale);
  pr.log_noise_var = 0.0;
  if (with_gradient) {
    const Mat G = post.kernel.cross_gradient_x(x, post.X);  // D × N, column i = ∂k(x, X_i)/∂x
    pr.d_mean = scale * (G * post.alpha);
    // ∂/∂x (σ² − k'K⁻¹k) = −2 G K⁻¹k
    pr.d_latent_var = var_std > 0 ? Vec(-2.0 * scale * scale * (G * post.llt.matrixU().solve(v))) : Vec::Zero(d);
    pr.d_log_noise_mean = Vec::Zero(d);
    pr.d_log_noise_var = Vec::Zero(d);
  }
  return pr;
}

double GpSurrogate::signal_variance() const {
  return signal_known_ ? std::exp(2.0 * log_signal_std_) : std::exp(2.0 * settings_.priors.signal_std.mean);
}

Hyperparameters GpSurrogate::hyperparameters() const {
  Hyperparameters h;
  for (Index i = 0; i < log_lengthscale_.size(); ++i) h.push_back({lengthscale_name(i), std::exp(log_lengthscale_(i))});
  h.push_back({"signal_std", std::sqrt(signal_variance())});
  h.push_back({"noise_std", std::exp(noise_known_ ? log_noise_std_ : settings_.priors.noise_std.mean)});
  h.push_back({"mean", mean_});
  return h;
}

void GpSurrogate::set_hyperparameters(const Hyperparameters& values) {
  std::vector<std::string> known;
  for (const auto& h : hyperparameters()) known.push_back(h.name);
  // Validate everything before changing anything.
  for (const auto& h : values) {
    bool found = false;
    for (const auto& k : known) found = found || k == h.name;
    if (!found) {
      const std::string near = closest_match(h.name, known);
      throw ConfigError("gp: unknown hyperparameter '" + h.name + "'; known: " + join(known) +
                        (near.empty() ? "" : "; did you mean '" + near + "'?"));
    }
    if (!std::isfinite(h.value) || (h.name != "mean" && !(h.value > 0)))
      throw ConfigError("gp: hyperparameter '" + h.name + "' must be " +
                        (h.name == "mean" ? "a finite number" : "a positive number") + ", got " +
                        std::to_string(h.value));
  }
  for (const auto& h : values) {
    if (h.name == "signal_std") {
      log_signal_std_ = std::log(h.value);
      signal_known_ = true;
    } else if (h.name == "noise_std") {
      log_noise_std_ = std::log(h.value);
      noise_known_ = true;
    } else if (h.name == "mean") {
      mean_ = h.value;
      mean_fixed_ = true;
    } else {
      for (Index i = 0; i < log_lengthscale_.size(); ++i)
        if (h.name == lengthscale_name(i)) log_lengthscale_(i) = std::log(h.value);
    }
  }
  if (data_) {
    const Dataset data = *data_;
    const FitReport rep = condition(data);
    if (!rep.ok) log_warn("gp: the new hyperparameters could not be conditioned on the data: {}", rep.message);
  }
}

}  // namespace varbo::gp
