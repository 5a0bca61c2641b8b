#include "gp_surrogate.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include "kernel_library.hpp"
#include "noise_bound.hpp"
#include "varbo/config.hpp"
#include "varbo/errors.hpp"
#include "varbo/text.hpp"
#include "varbo/log.hpp"
#include "varbo/restarts.hpp"

namespace varbo::gp {

namespace {
constexpr double kLog2Pi = 1.8378770664093454836;
/// Costs whose spread is within this fraction of their mean are constant to the double they are stored in (64 ulps).
constexpr double kConstantSpread = 64 * std::numeric_limits<double>::epsilon();

Vec clamp_to(const Box& box, const Vec& p) { return p.cwiseMax(box.lower).cwiseMin(box.upper); }
}  // namespace

GpSurrogate::GpSurrogate(Index dim, GpSettings settings, std::shared_ptr<const Optimizer> fit_optimizer)
    : dim_(dim), settings_(settings), optimizer_(std::move(fit_optimizer)) {
  if (!optimizer_) throw std::invalid_argument("GpSurrogate: a fit optimizer is required");
  if (!settings_.kernel_candidates.empty()) {  // the first candidate until a fit chooses
    settings_.kernel = settings_.kernel_candidates.front().make;
    settings_.min_noise_std = settings_.kernel_candidates.front().min_noise_std;
  }
  ensure_dim(dim);
}

namespace {
/// A Dataset assembled by hand (the SDK's own loop) with X.rows() ≠ y.size() was read past its end (red team,
/// session 27).
void check_shape(const Dataset& data) {
  if (data.X.rows() != data.y.size())
    throw InputError(fmt::format("gp: the data have {} points in X but {} costs in y", data.X.rows(), data.y.size()));
}
}  // namespace

void GpSurrogate::ensure_dim(Index d) {
  if (kernel_ && kernel_->dim() == d) return;
  dim_ = d;
  if (d < 1) {
    kernel_.reset();  // no kernel before the dimension is known (a surrogate built with dim 0)
    kernel_log_.resize(0);
    kernel_known_.clear();
    return;
  }
  kernel_ = settings_.kernel ? settings_.kernel(d) : kernels::make_stationary_ard(kernels::KernelType::Matern52, d);
  if (!kernel_ || kernel_->dim() != d) throw std::invalid_argument("gp: the kernel does not have the data's dimension");
  const GpSettings& s = settings_;
  kernel_->set_role_defaults(KernelParameterRole::Lengthscale, s.priors.lengthscale, s.min_lengthscale,
                             s.max_lengthscale);
  kernel_->set_role_defaults(KernelParameterRole::Amplitude, s.priors.signal_std, s.min_signal_std, s.max_signal_std);
  kernel_->set_role_defaults(KernelParameterRole::Noise, s.priors.noise_std, s.min_noise_std, s.max_noise_std);
  // Start at the prior medians (whether or not the priors are used in the objective); values that scale with the
  // costs stay unknown until given or fitted, since their median is relative to std(y).
  const Index m = kernel_->num_params();
  kernel_log_.resize(m);
  kernel_known_.assign(static_cast<std::size_t>(m), 0);
  for (Index j = 0; j < m; ++j) {
    const KernelParameter& p = kernel_->parameters()[static_cast<std::size_t>(j)];
    kernel_log_(j) = p.prior.mean;
    kernel_known_[static_cast<std::size_t>(j)] = !p.scales_with_output;
  }
}

void GpSurrogate::select_kernel(std::size_t c) {
  const std::vector<KernelCandidate>& cands = settings_.kernel_candidates;
  if (c >= cands.size()) {
    if (c == 0) return;  // no candidates: `kernel` alone
    throw std::out_of_range("gp: kernel candidate out of range");
  }
  if (c == choice_ && kernel_) return;
  settings_.kernel = cands[c].make;
  settings_.min_noise_std = cands[c].min_noise_std;
  choice_ = c;
  // The candidates share their hyperparameter names (gp_component.cpp checks it), so the current values carry
  // over as the new kernel's warm start.
  const Vec values = kernel_log_;
  const std::vector<char> known = kernel_known_;
  kernel_.reset();
  ensure_dim(dim_);
  if (values.size() == kernel_log_.size()) {
    kernel_log_ = values;
    kernel_known_ = known;
  }
}

double GpSurrogate::log_scale_of(Index j, double y_scale) const {
  return kernel_->parameters()[static_cast<std::size_t>(j)].scales_with_output ? std::log(y_scale) : 0.0;
}

Vec GpSurrogate::natural_kernel_log() const {
  Vec n = kernel_log_;
  for (Index j = 0; j < n.size(); ++j)
    if (!kernel_known_[static_cast<std::size_t>(j)]) n(j) = kernel_->parameters()[static_cast<std::size_t>(j)].prior.mean;
  return n;
}

Box GpSurrogate::log_box(Index d) const {
  if (!kernel_ || kernel_->dim() != d) throw std::invalid_argument("gp: log_box for another dimension");
  const Box k = kernel_->log_box();
  const Index m = k.dim();
  Box b;
  b.lower.resize(m + 1);
  b.upper.resize(m + 1);
  b.lower.head(m) = k.lower;
  b.upper.head(m) = k.upper;
  b.lower(m) = std::log(settings_.min_noise_std);
  b.upper(m) = std::log(settings_.max_noise_std);
  return b;
}

GpSurrogate::Standardization GpSurrogate::standardization(const Vec& y) {
  Standardization s;
  const Index n = y.size();
  if (n == 0) return s;
  s.shift = y.mean();
  const double var = n > 1 ? (y.array() - s.shift).square().sum() / static_cast<double>(n - 1) : 0.0;
  double sd = std::sqrt(var);
  if (!std::isfinite(sd)) {
    // Costs near the double range (1e200): the squares overflowed, the scale fell back to 1, and every fit failed
    // as a "Cholesky failure" while bo went on at random (session 20). The moments of y / max|y|, scaled back.
    const double a = y.cwiseAbs().maxCoeff();
    if (std::isfinite(a) && a > 0) {
      const Vec z = y / a;
      s.shift = a * z.mean();
      sd = a * std::sqrt((z.array() - z.mean()).square().sum() / static_cast<double>(n - 1));
    }
  }
  // Constant (or single) costs carry no scale: keep 1 so the model stays well defined. "Constant" is relative to
  // the costs' magnitude only: costs of order 1e-13 that vary were modelled as constant under an absolute floor;
  // and it means a spread of a few ulps of the mean (rounding), not 1e-12 of it: costs of 1e15 + y with y spanning
  // 300 are known to ~0.1 and were modelled with scale 1 and a capped signal (session 25).
  s.scale = (std::isfinite(sd) && sd > kConstantSpread * std::abs(s.shift) && sd > 1e-290) ? sd : 1.0;
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
  const Index m = kernel_log_.size();
  Vec p(m + 1);
  for (Index j = 0; j < m; ++j) {
    const KernelParameter& k = kernel_->parameters()[static_cast<std::size_t>(j)];
    if (!kernel_known_[static_cast<std::size_t>(j)])
      p(j) = k.prior.mean;
    else
      p(j) = k.scales_with_output ? kernel_log_(j) - std::log(y_scale) : kernel_log_(j);
  }
  p(m) = noise_known_ ? log_noise_std_ - std::log(y_scale) : settings_.priors.noise_std.mean;
  return p;
}

void GpSurrogate::store_natural(const Vec& p, const Standardization& s) {
  const Index m = kernel_log_.size();
  for (Index j = 0; j < m; ++j) kernel_log_(j) = p(j) + log_scale_of(j, s.scale);
  kernel_known_.assign(static_cast<std::size_t>(m), 1);
  log_noise_std_ = p(m) + std::log(s.scale);
  noise_known_ = true;
  if (!mean_fixed_) mean_ = s.shift + s.scale * mean_standardized(s);
}

std::optional<GpSurrogate::Posterior> GpSurrogate::build(const Dataset& data, const Standardization& s,
                                                          const Vec& p) const {
  const Index n = data.size(), m = kernel_ ? kernel_->num_params() : 0;
  std::unique_ptr<Kernel> kernel = kernel_ ? kernel_->clone() : nullptr;  // none before the dimension is known
  if (kernel) kernel->set_log_params(p.head(m));
  Posterior post{std::move(kernel), std::exp(2.0 * p(m)), mean_standardized(s),
                 data.X, Vec(), Eigen::LLT<Mat>(Mat(0, 0)), 0.0, 0.0, s, p};  // an initialized (empty) factor
  if (n == 0) return post;
  const Vec r = (data.y.array() - s.shift).matrix() / s.scale - Vec::Constant(n, post.mean);
  Mat K = post.kernel->checked_matrix(data.X);
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
  rep.log_prior = settings_.priors.log_density(*kernel_, p, nullptr);
  rep.objective = rep.log_likelihood + rep.log_prior;
  if (post.jitter > 0) {
    // {:.3g}: std::to_string printed a 300-digit number for inputs near 1e150 (red team, session 37).
    rep.message = fmt::format("jitter {:.3g} added to the diagonal", post.jitter);
    // A jitter above the kernel's own prior variance (standardized units, at the centre of the cube: σ_f² of a
    // stationary kernel, as signal_variance()) outweighs the covariance it was added to: the model no longer
    // follows the data. Said in the report; `ok` stays true, which means the model was installed (false: the
    // previous one was kept), and it was.
    const double signal = post.kernel ? post.kernel->diagonal(Vec::Constant(post.X.cols(), 0.5)) : 0.0;
    if (!(post.jitter <= signal))
      rep.message += fmt::format(
          "; warning: more than the kernel's signal variance ({:.3g}, standardized costs): the fit is dominated by "
          "the jitter and does not follow the data (inputs of very different scales? rescale them, or choose "
          "another kernel)",
          signal);
  }
  return rep;
}

FitReport GpSurrogate::condition(const Dataset& data) {
  const auto t0 = std::chrono::steady_clock::now();
  check_shape(data);
  ensure_dim(data.dim());
  const Standardization s = standardization(data.y);
  const Vec p = log_params(s.scale);
  auto post = build(data, s, p);
  FitReport rep;
  if (post) {
    rep = report_for(*post, p);
    // Conditioned before any fit chose among the kernel candidates (`varbo fit --no-optimize` with kernel: auto):
    // the first candidate is used. Said, since a fit's hyperparameters fed back this way had come from the
    // kernel the fit chose (se_ard) and gave another model without a word (audit, session 48).
    if (!settings_.kernel_candidates.empty() && !posterior_) {
      const auto& cands = settings_.kernel_candidates;
      const std::string said = fmt::format(
          "kernel {} (the first of the kernel candidates: only a fit chooses among them; to condition with another, "
          "name it, e.g. kernel: {})",
          cands[choice_].name, cands[choice_ + 1 < cands.size() ? choice_ + 1 : 0].name);
      rep.message = rep.message.empty() ? said : said + "; " + rep.message;
    }
    store_natural(p, s);
    posterior_ = std::move(post);
    data_ = data;
  } else {
    rep.ok = false;
    // Say what the caller is left with: a first condition() has no model to keep (red team, session 31).
    rep.message = posterior_ ? "Cholesky failed even with jitter; the previous model is kept"
                             : "Cholesky failed even with jitter; no model (nothing fitted before)";
    log_warn("gp: {}", rep.message);
  }
  rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return rep;
}

Restarts<OptimizeResult> GpSurrogate::run_restarts_for(const Dataset& data, const Standardization& s, Index restarts,
                                                       const Rng& rng, std::uint64_t base) const {
  const Index d = data.dim(), n = data.size();
  Box box = log_box(d);
  const Vec r = (data.y.array() - s.shift).matrix() / s.scale - Vec::Constant(n, mean_standardized(s));
  HyperPriors priors = settings_.priors;
  if (settings_.noise_test_level > 0) {
    // The data's own bound on the noise (standardized units, as the box): the noise mode cannot take what near
    // pairs show to be structure (GpSettings::noise_test_level).
    const double cap = near_pair_noise_bound(data.X, r, settings_.noise_test_level).bound;
    const Index last = box.dim() - 1;
    if (settings_.noise_test_tight && cap <= kNoNoiseBound) {
      priors.noise_std = {std::log(kTightNoiseMedian), kTightNoiseSd};
    } else if (std::isfinite(cap)) {
      // A bound of 0 (exact replicates) puts the upper end on the floor: log(0) is kept out by the max.
      box.upper(last) = std::clamp(std::log(std::max(cap, 1e-300)), box.lower(last), box.upper(last));
    }
  }
  const LogPosterior objective(*kernel_, data.X, r, priors, box);
  const BoxRegion region(box);

  // Start 0: warm start from the current hyperparameters; the others drawn from the hyperpriors (or
  // uniformly in the log box when the priors are off), each from its own stream: thread-count independent.
  std::vector<Rng> streams;
  const Index m = kernel_->num_params(), np = m + 1;
  Mat starts(restarts, np);
  for (Index k = 0; k < restarts; ++k) {
    streams.push_back(rng.stream(base, static_cast<std::uint64_t>(k)));
    Vec p(np);
    if (k == 0) {
      p = log_params(s.scale);
    } else {
      Rng& g = streams.back();
      const HyperPriors& pr = priors;
      for (Index j = 0; j < np; ++j) {
        const LogNormalPrior& prior =
            j < m ? kernel_->parameters()[static_cast<std::size_t>(j)].prior : pr.noise_std;
        p(j) = pr.enabled ? prior.mean + prior.sd * g.normal() : g.uniform(box.lower(j), box.upper(j));
      }
    }
    starts.row(k) = clamp_to(box, p).transpose();
  }

  // Each start on its own stream (advanced above by the draw of its start), reduced in index order.
  return run_restarts<OptimizeResult>(
      restarts, [&](Index k) { return streams[static_cast<std::size_t>(k)]; },
      [&](Index k, Rng& stream) {
        OptimizeResult res;
        try {
          res = optimizer_->maximize(objective, region, starts.row(k), stream);
          if (res.success && res.x.size() == np && res.x.allFinite()) {
            // The optimizer may ignore the box (ceres_lbfgs): clamp and score the point actually used.
            res.x = clamp_to(box, res.x);
            res.value = objective.value(res.x, nullptr);
            res.success = std::isfinite(res.value);
          } else {
            res.success = false;
          }
        } catch (const PluginCodeError&) {
          throw;  // a component's code is wrong (a kernel's result of the wrong size): no restart is usable
        } catch (const std::exception& e) {
          res.success = false;
          res.message = e.what();
        } catch (...) {  // as a std::exception: a failed restart (it stopped the run, red team, session 28)
          res.success = false;
          res.message = "the fit optimizer threw something that is not a std::exception";
        }
        return res;
      },
      [](const OptimizeResult& res) { return res.success ? std::optional<double>(res.value) : std::nullopt; });
}

FitReport GpSurrogate::fit(const Dataset& data, Rng& rng) {
  const auto t0 = std::chrono::steady_clock::now();
  check_shape(data);
  ensure_dim(data.dim());
  if (data.size() == 0) return condition(data);
  const Index n = data.size();
  const Standardization s = standardization(data.y);

  // Between full fits only the warm start runs (issue 13: most restarts of a refit on one more point end in
  // the optimum the warm start reaches); below kAlwaysFullFit points the hyperparameters still move a lot.
  constexpr Index kAlwaysFullFit = 20;
  bool kernel_known = true;
  for (const char k : kernel_known_) kernel_known = kernel_known && k;
  const bool warm_known = kernel_known && noise_known_ && posterior_.has_value();
  const bool full = !warm_known || n <= kAlwaysFullFit || settings_.full_fit_growth <= 1.0 || last_full_fit_n_ == 0 ||
                    n < last_full_fit_n_ ||
                    static_cast<double>(n) >= settings_.full_fit_growth * static_cast<double>(last_full_fit_n_);
  const Index restarts = full ? std::max(1, settings_.restarts) : 1;
  const std::uint64_t base = rng.next();

  // With kernel_candidates a full fit fits each candidate (in order, from the same warm start and streams) and
  // keeps the highest objective; a warm-only refit keeps the chosen kernel.
  const std::size_t n_cand = settings_.kernel_candidates.size();
  const bool choose = full && n_cand >= 2;
  const std::size_t previous = choice_;
  const bool first_choice = last_full_fit_n_ == 0;
  std::optional<Posterior> post;
  Vec p;
  Index failed = 0;
  std::size_t chosen = previous;
  std::string scores;  // "matern52_ard -12.3, se_ard -10.1": the fit objective of each candidate
  std::string first_failure;  // why the first failed restart failed (said when every restart fails)
  // Per candidate the best restart's log-parameters and objective (−∞: every restart or the posterior failed).
  std::vector<Vec> params;
  std::vector<double> values;
  for (std::size_t c = choose ? 0 : previous; c < (choose ? n_cand : previous + 1); ++c) {
    if (choose) select_kernel(c);
    const Restarts<OptimizeResult> run = run_restarts_for(data, s, restarts, rng, base);
    failed += run.failed;
    for (const OptimizeResult& r : run.results)
      if (first_failure.empty() && !r.success && !r.message.empty()) first_failure = r.message;
    double value = -std::numeric_limits<double>::infinity();
    Vec x;
    if (run.best >= 0) {
      const OptimizeResult& r = run.results[static_cast<std::size_t>(run.best)];
      x = r.x;
      // Candidates whose posterior fails are out of the choice; a single kernel builds it once, below.
      if (!choose || build(data, s, x)) value = r.value;
    }
    if (choose)
      scores += fmt::format("{}{} {}", c == 0 ? "" : ", ", settings_.kernel_candidates[c].name,
                            std::isfinite(value) ? fmt::format("{:.6g}", value - static_cast<double>(n) * std::log(s.scale))
                                                 : std::string("failed"));  // in cost units, as FitReport::objective
    params.push_back(std::move(x));
    values.push_back(value);
  }
  // The first candidate within kernel_choice_margin of the best objective (margin 0: the best; a tie keeps the
  // earlier one): a margin makes the list an order of preference.
  const double best_value = *std::max_element(values.begin(), values.end());
  std::optional<std::size_t> pick;
  for (std::size_t i = 0; i < values.size() && !pick; ++i)
    if (std::isfinite(values[i]) && values[i] >= best_value - settings_.kernel_choice_margin) pick = i;
  if (pick) chosen = choose ? *pick : previous;
  // The fits of the candidates left the last one in place: back to the chosen one (or the previous one when
  // all failed), with the current values as its warm start; its posterior rebuilt (build is deterministic).
  if (choose) select_kernel(chosen);
  if (pick) {
    p = params[*pick];
    post = build(data, s, p);
  }

  FitReport rep;
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
    if (choose) {
      const std::string& name = settings_.kernel_candidates[chosen].name;
      const std::string note = "kernel " + name + " (fit objective: " + scores + ")";
      rep.message = rep.message.empty() ? note : note + "; " + rep.message;
      // To the log when the choice changes (the first choice only with -v: `kernel: auto` is the default, and
      // `varbo select` prints JSON); model.yaml's note has it at every full fit.
      if (first_choice)
        log_debug("gp: N = {}: {}", n, note);
      else if (chosen != previous)
        log_info("gp: N = {}: {}", n, note);
    }
  } else {
    // Keep the last good hyperparameters; condition them on the new data when that still works.
    rep = condition(data);
    rep.ok = false;
    // The reason was dropped: a fit optimizer's own exception read only "every restart failed" (red team,
    // session 28).
    rep.message = "every restart failed" +
                  (first_failure.empty() ? std::string() : " (the first: " + safe_text(first_failure, 300) + ")") +
                  "; kept the previous hyperparameters" +
                  (rep.message.empty() ? std::string() : " (" + rep.message + ")");
    log_warn("gp: {}", rep.message);
  }
  rep.restarts = static_cast<int>(restarts * (choose ? static_cast<Index>(n_cand) : 1));
  rep.restarts_failed = static_cast<int>(failed);
  rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return rep;
}

Prediction GpSurrogate::predict(const Vec& x, bool with_gradient) const {
  Prediction pr;
  const Index d = x.size();
  if (dim_ > 0 && d != dim_)  // a point of another dimension gave a number in silence
    throw InputError(fmt::format("gp: predict at a point of dimension {}, the model's is {}", d, dim_));
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
  const Vec k = post.kernel->checked_cross_vec(x, post.X);
  const Vec v = post.llt.matrixL().solve(k);
  // R&W eqs. (2.25)–(2.26), standardized, then mapped back to cost units.
  const double var_std = post.kernel->diagonal(x) - v.squaredNorm();
  pr.mean = post.stdz.shift + scale * (post.mean + k.dot(post.alpha));
  pr.latent_var = scale * scale * std::max(var_std, 0.0);
  pr.log_noise_mean = std::log(post.noise_var) + 2.0 * std::log(scale);
  pr.log_noise_var = 0.0;
  if (with_gradient) {
    const Mat G = post.kernel->checked_cross_gradient_x(x, post.X);  // D × N, column i = ∂k(x, X_i)/∂x
    pr.d_mean = scale * (G * post.alpha);
    // ∂/∂x (σ² − k'K⁻¹k) = −2 G K⁻¹k
    pr.d_latent_var = var_std > 0 ? Vec(-2.0 * scale * scale * (G * post.llt.matrixU().solve(v))) : Vec::Zero(d);
    pr.d_log_noise_mean = Vec::Zero(d);
    pr.d_log_noise_var = Vec::Zero(d);
  }
  return pr;
}

double GpSurrogate::predict_mean(const Vec& x) const {
  // predict()'s mean, computed the same way (bit for bit: the recommendation compares these), without v = L⁻¹k.
  if (dim_ > 0 && x.size() != dim_)
    throw InputError(fmt::format("gp: predict at a point of dimension {}, the model's is {}", x.size(), dim_));
  if (!posterior_ || posterior_->X.rows() == 0) return mean_;
  const Posterior& post = *posterior_;
  const Vec k = post.kernel->checked_cross_vec(x, post.X);
  return post.stdz.shift + post.stdz.scale * (post.mean + k.dot(post.alpha));
}

double GpSurrogate::signal_variance() const {
  if (!kernel_) return std::exp(2.0 * settings_.priors.signal_std.mean);
  // k(c, c) at the centre c of the cube in natural units (σ_f² for a stationary kernel).
  const std::unique_ptr<Kernel> k = kernel_->clone();
  k->set_log_params(natural_kernel_log());
  return k->diagonal(Vec::Constant(kernel_->dim(), 0.5));
}

Hyperparameters GpSurrogate::hyperparameters() const {
  Hyperparameters h;
  const Vec n = kernel_ ? natural_kernel_log() : Vec();
  for (Index j = 0; j < n.size(); ++j) {
    const KernelParameter& p = kernel_->parameters()[static_cast<std::size_t>(j)];
    // sqrt(exp(2 log σ)) for amplitudes: the same bits as σ_f = sqrt(signal_variance()) of the fixed-kernel gp.
    h.push_back({p.name, p.role == KernelParameterRole::Amplitude ? std::sqrt(std::exp(2.0 * n(j))) : std::exp(n(j))});
  }
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
    if (h.name == "noise_std") {
      log_noise_std_ = std::log(h.value);
      noise_known_ = true;
    } else if (h.name == "mean") {
      mean_ = h.value;
      mean_fixed_ = true;
    } else {
      for (Index j = 0; j < kernel_log_.size(); ++j)
        if (h.name == kernel_->parameters()[static_cast<std::size_t>(j)].name) {
          kernel_log_(j) = std::log(h.value);
          kernel_known_[static_cast<std::size_t>(j)] = 1;
        }
    }
  }
  if (data_) {
    const Dataset data = *data_;
    const FitReport rep = condition(data);
    if (!rep.ok) log_warn("gp: the new hyperparameters could not be conditioned on the data: {}", rep.message);
  }
}

}  // namespace varbo::gp
