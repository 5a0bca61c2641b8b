#include "homoscedastic_init.hpp"

#include <cmath>
#include <limits>
#include <vector>

namespace varbo::vhgp {

double homoscedastic_log_likelihood(const Mat& X, const Vec& y, KernelType type, double jitter, const Vec& x,
                                    Vec* grad) {
  const Index n = y.size(), dim = X.cols();
  const double minus_inf = -std::numeric_limits<double>::infinity();
  if (grad) *grad = Vec::Zero(dim + 2);
  if (!x.allFinite()) return minus_inf;
  ArdKernel k(type, dim);
  k.set_log_params(x.head(dim + 1));
  const double noise = std::exp(2.0 * x(dim + 1));
  Mat K = k.matrix(X);
  K.diagonal().array() += jitter * k.variance() + noise;
  Eigen::LLT<Mat> llt(K);
  if (llt.info() != Eigen::Success) return minus_inf;
  const Vec alpha = llt.solve(y);
  const double value = -0.5 * y.dot(alpha) - llt.matrixLLT().diagonal().array().log().sum() -
                       0.5 * n * std::log(2.0 * M_PI);
  if (!std::isfinite(value)) return minus_inf;
  if (grad) {
    // ∂/∂θ = ½ tr((αα' − K⁻¹) ∂K/∂θ)   (R&W eq. 5.9)
    const Mat W = alpha * alpha.transpose() - llt.solve(Mat::Identity(n, n));
    grad->head(dim + 1) = k.contract_gradient(X, W);
    (*grad)(dim) += jitter * k.variance() * W.trace();
    (*grad)(dim + 1) = noise * W.trace();
  }
  return value;
}

Vec homoscedastic_coordinates(const HomoscedasticFit& fit) {
  Vec x(fit.theta_f.size() + 1);
  x << fit.theta_f, 0.5 * fit.log_noise_var;
  return x;
}

HomoscedasticFit fit_homoscedastic(const Mat& X, const Vec& y, KernelType type, double jitter,
                                   const VhgpHyperprior& prior, const Optimizer& optimizer, Rng& rng,
                                   const Vec* warm, bool warm_only) {
  const Index dim = X.cols();
  const double var_y = std::max(y.squaredNorm() / std::max<Index>(y.size(), 1), 1e-12);
  FunctionRef objective(dim + 2, [&](const Vec& x, Vec* grad) {
    double v = homoscedastic_log_likelihood(X, y, type, jitter, x, grad);
    if (!std::isfinite(v) || !prior.enabled) return v;
    double d = 0;
    for (Index i = 0; i <= dim; ++i) {
      v += (i < dim ? prior.lengthscale_f : prior.signal_f).log_density(x(i), &d);
      if (grad) (*grad)(i) += d;
    }
    v += prior.mu0.log_density(2.0 * x(dim + 1), &d);  // μ0 plays the role of log σ_n²
    if (grad) (*grad)(dim + 1) += 2.0 * d;
    return v;
  });
  Vec start(dim + 2);
  start.head(dim).setConstant(std::log(0.5));
  start(dim) = 0.5 * std::log(var_y);
  start(dim + 1) = 0.5 * std::log(var_y / 4.0);
  Box box{Vec::Constant(dim + 2, std::log(1e-3)), Vec::Constant(dim + 2, std::log(1e3))};
  box.lower(dim + 1) = std::log(1e-6);
  box.upper(dim) = box.upper(dim + 1) = std::log(1e2);
  const BoxRegion region(box);
  HomoscedasticFit fit;
  // Several lengthscales: from ℓ = 0.5 alone, data with a short-period mean (the two-minima task at N = 20)
  // sometimes converged to the flat "everything is noise" optimum, and every VHGP start inherited it.
  std::vector<Vec> starts;
  if (warm != nullptr && warm->size() == dim + 2 && warm->allFinite()) starts.push_back(box.clamp(*warm));
  if (starts.empty() || !warm_only) {
    for (const double lengthscale : {0.5, 0.15, 0.05}) {
      starts.push_back(start);
      starts.back().head(dim).setConstant(std::log(lengthscale));
    }
  }
  OptimizeResult res;
  res.value = -std::numeric_limits<double>::infinity();
  for (const Vec& x0 : starts) {
    OptimizeResult r;
    try {
      r = optimizer.maximize(objective, region, x0.transpose(), rng);
    } catch (const std::exception&) {
      continue;
    }
    if (r.x.size() == dim + 2 && r.x.allFinite() && std::isfinite(r.value) && r.value > res.value) res = r;
  }
  if (res.x.size() != dim + 2 || !res.x.allFinite() || !std::isfinite(res.value)) {
    res.x = start;  // fall back to the authors' start values
    res.value = objective.value(start, nullptr);
  }
  fit.ok = std::isfinite(res.value);
  fit.theta_f = res.x.head(dim + 1);
  fit.log_noise_var = 2.0 * res.x(dim + 1);
  fit.log_likelihood = res.value;
  return fit;
}

}  // namespace varbo::vhgp
