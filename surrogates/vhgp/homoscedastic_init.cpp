#include "homoscedastic_init.hpp"

#include <cmath>
#include <limits>
#include <vector>

#include "varbo/errors.hpp"

namespace varbo::vhgp {

double homoscedastic_log_likelihood(const Mat& X, const Vec& y, const Kernel& kernel, double jitter, const Vec& x,
                                    Vec* grad) {
  const Index n = y.size(), m = kernel.num_params();
  const double minus_inf = -std::numeric_limits<double>::infinity();
  if (grad) *grad = Vec::Zero(m + 1);
  if (!x.allFinite() || x.size() != m + 1) return minus_inf;
  const JitteredKernel k(kernel, x.head(m), jitter);
  const double noise = std::exp(2.0 * x(m));
  Mat K = k.training_matrix(X);
  K.diagonal().array() += noise;
  Eigen::LLT<Mat> llt(K);
  if (llt.info() != Eigen::Success) return minus_inf;
  const Vec alpha = llt.solve(y);
  const double value = -0.5 * y.dot(alpha) - llt.matrixLLT().diagonal().array().log().sum() -
                       0.5 * n * std::log(2.0 * M_PI);
  if (!std::isfinite(value)) return minus_inf;
  if (grad) {
    // ∂/∂θ = ½ tr((αα' − K⁻¹) ∂K/∂θ)   (R&W eq. 5.9)
    const Mat W = alpha * alpha.transpose() - llt.solve(Mat::Identity(n, n));
    grad->head(m) = k.contract_gradient(X, W);
    (*grad)(m) = noise * W.trace();
  }
  return value;
}

Vec homoscedastic_coordinates(const HomoscedasticFit& fit) {
  Vec x(fit.theta_f.size() + 1);
  x << fit.theta_f, 0.5 * fit.log_noise_var;
  return x;
}

HomoscedasticFit fit_homoscedastic(const Mat& X, const Vec& y, const Kernel& kernel, double jitter,
                                   const VhgpHyperprior& prior, const Optimizer& optimizer, Rng& rng,
                                   const Vec* warm, bool warm_only) {
  const Index m = kernel.num_params();
  const double var_y = std::max(y.squaredNorm() / std::max<Index>(y.size(), 1), 1e-12);
  FunctionRef objective(m + 1, [&](const Vec& x, Vec* grad) {
    double v = homoscedastic_log_likelihood(X, y, kernel, jitter, x, grad);
    if (!std::isfinite(v) || !prior.enabled) return v;
    Vec gk;
    v += kernel.log_prior(x.head(m), grad ? &gk : nullptr);
    if (grad) grad->head(m) += gk;
    double d = 0;
    v += prior.mu0.log_density(2.0 * x(m), &d);  // μ0 plays the role of log σ_n²
    if (grad) (*grad)(m) += 2.0 * d;
    return v;
  });
  const double log_noise_start = 0.5 * std::log(var_y / 4.0);
  Vec start(m + 1);
  start << values_by_role(kernel, std::log(0.5), 0.5 * std::log(var_y), log_noise_start), log_noise_start;
  const Box kernel_box = kernel.log_box();
  Box box{Vec(m + 1), Vec(m + 1)};
  box.lower << kernel_box.lower, std::log(1e-6);
  box.upper << kernel_box.upper, std::log(1e2);
  const BoxRegion region(box);
  HomoscedasticFit fit;
  // Several lengthscales: from ℓ = 0.5 alone, data with a short-period mean (the two-minima task at N = 20)
  // sometimes converged to the flat "everything is noise" optimum, and every VHGP start inherited it.
  std::vector<Vec> starts;
  if (warm != nullptr && warm->size() == m + 1 && warm->allFinite()) starts.push_back(box.clamp(*warm));
  if (starts.empty() || !warm_only) {
    for (const double lengthscale : {0.5, 0.15, 0.05}) {
      starts.push_back(start);
      for (Index j = 0; j < m; ++j)
        if (kernel.parameters()[static_cast<std::size_t>(j)].role == KernelParameterRole::Lengthscale)
          starts.back()(j) = std::log(lengthscale);
    }
  }
  OptimizeResult res;
  res.value = -std::numeric_limits<double>::infinity();
  for (const Vec& x0 : starts) {
    OptimizeResult r;
    try {
      r = optimizer.maximize(objective, region, x0.transpose(), rng);
    } catch (const PluginCodeError&) {
      throw;  // a component's code is wrong: no start is usable
    } catch (const std::exception&) {
      continue;
    }
    if (r.x.size() == m + 1 && r.x.allFinite() && std::isfinite(r.value) && r.value > res.value) res = r;
  }
  if (res.x.size() != m + 1 || !res.x.allFinite() || !std::isfinite(res.value)) {
    res.x = start;  // fall back to the authors' start values
    res.value = objective.value(start, nullptr);
  }
  fit.ok = std::isfinite(res.value);
  fit.theta_f = res.x.head(m);
  fit.log_noise_var = 2.0 * res.x(m);
  fit.log_likelihood = res.value;
  return fit;
}

}  // namespace varbo::vhgp
