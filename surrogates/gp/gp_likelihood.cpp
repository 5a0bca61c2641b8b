#include "gp_likelihood.hpp"

#include <cmath>
#include <limits>

#include "triangular_ops.hpp"

namespace varbo::gp {

Mat inverse_from_cholesky(const Eigen::LLT<Mat>& llt) {
  // The recursive triangular inverse shared with the vhgp (n³/3 flops against n³ for a solve against I).
  const Mat Li = linalg::lower_triangular_inverse(llt.matrixLLT());
  // K⁻¹ = L⁻ᵀ L⁻¹ (triangular × dense product).
  return Li.transpose().triangularView<Eigen::Upper>() * Li;
}

LogMarginal log_marginal_likelihood(const Kernel& form, const Vec& log_params, const Mat& X, const Vec& r,
                                    bool with_gradient) {
  const Index n = X.rows(), m = form.num_params();
  LogMarginal out;
  const std::unique_ptr<Kernel> kernel = form.clone();  // one copy per evaluation: thread-safe, N² work dominates
  kernel->set_log_params(log_params.head(m));
  const double noise_var = std::exp(2.0 * log_params(m));
  Mat K = kernel->checked_matrix(X);
  K.diagonal().array() += noise_var;
  RobustCholesky chol = robust_cholesky(K);
  if (!chol.ok) {
    out.value = std::numeric_limits<double>::quiet_NaN();
    return out;
  }
  out.jitter = chol.jitter;
  const Vec alpha = chol.llt.solve(r);
  // R&W eq. (5.8): −½ r'K⁻¹r − ½ log|K| − n/2 log 2π, with ½ log|K| = Σ log L_ii.
  out.value = -0.5 * r.dot(alpha) - chol.llt.matrixLLT().diagonal().array().log().sum() -
              0.5 * static_cast<double>(n) * std::log(2.0 * M_PI);
  out.ok = std::isfinite(out.value);
  if (!with_gradient || !out.ok) return out;
  // R&W eq. (5.9): W = αα' − K⁻¹, ∂/∂p_j = ½ tr(W ∂K/∂p_j).
  Mat W = inverse_from_cholesky(chol.llt);
  W = alpha * alpha.transpose() - W;
  out.gradient.resize(m + 1);
  out.gradient.head(m) = kernel->checked_contract_gradient(X, W);
  // ∂K/∂log σ_n = 2σ_n² I (the jitter does not depend on σ_n).
  out.gradient(m) = noise_var * W.trace();
  out.ok = out.gradient.allFinite();
  return out;
}

double HyperPriors::log_density(const Kernel& kernel, const Vec& log_params, Vec* grad) const {
  const Index m = kernel.num_params();
  if (grad) grad->setZero(log_params.size());
  if (!enabled) return 0.0;
  // Kuindersma 2013, eq. (13): Σ_k log N(log ψ_k | μ_k, σ_k²), the kernel's terms first.
  Vec kernel_grad;
  double total = kernel.log_prior(log_params.head(m), grad ? &kernel_grad : nullptr);
  double dn = 0.0;
  total += noise_std.log_density(log_params(m), grad ? &dn : nullptr);
  if (grad) {
    grad->head(m) = kernel_grad;
    (*grad)(m) = dn;
  }
  return total;
}

LogPosterior::LogPosterior(const Kernel& kernel, Mat X, Vec r, HyperPriors priors, Box box)
    : kernel_(kernel.clone()), X_(std::move(X)), r_(std::move(r)), priors_(priors), box_(std::move(box)) {}

double LogPosterior::value(const Vec& p, Vec* grad) const {
  if (!p.allFinite()) return std::numeric_limits<double>::quiet_NaN();
  const LogMarginal lml = log_marginal_likelihood(*kernel_, p, X_, r_, grad != nullptr);
  if (!lml.ok) return std::numeric_limits<double>::quiet_NaN();
  Vec prior_grad;
  double v = lml.value + priors_.log_density(*kernel_, p, grad ? &prior_grad : nullptr);
  if (grad) *grad = lml.gradient + prior_grad;
  // Outside the box: −½ c · excess², c large enough to dominate the likelihood's slope there.
  constexpr double c = 1e3;
  for (Index j = 0; j < p.size(); ++j) {
    const double excess = p(j) < box_.lower(j) ? p(j) - box_.lower(j) : (p(j) > box_.upper(j) ? p(j) - box_.upper(j) : 0.0);
    if (excess == 0.0) continue;
    v -= 0.5 * c * excess * excess;
    if (grad) (*grad)(j) -= c * excess;
  }
  return v;
}

}  // namespace varbo::gp
