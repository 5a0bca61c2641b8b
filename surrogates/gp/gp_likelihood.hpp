#pragma once
// The exact-GP log marginal likelihood over log-hyperparameters, its gradient, and the log-normal
// hyperprior of Kuindersma 2013, eq. (13). Parameter vector (standardized cost units, unit cube):
//   p = [kernel log-parameters θ (e.g. log ℓ_1, ..., log ℓ_D, log σ_f), log σ_n]
#include <memory>

#include "varbo/function.hpp"
#include "varbo/kernel.hpp"
#include "varbo/math.hpp"

namespace varbo::gp {

struct LogMarginal {
  bool ok = false;
  double value = 0;   ///< log N(r | 0, K + σ_n² I)
  Vec gradient;       ///< d value / d p (filled when asked)
  double jitter = 0;  ///< added to the diagonal by robust_cholesky
};

/// (LLᵀ)⁻¹ from a Cholesky factor, using the triangular structure (≈ 0.8 N³ flops instead of 2 N³).
Mat inverse_from_cholesky(const Eigen::LLT<Mat>& llt);

/// log p(r | X, p) for centred targets r = y − m (Rasmussen & Williams eq. (5.8)), and its gradient
/// ∂/∂p_j = ½ tr((αα' − K⁻¹) ∂K/∂p_j) (R&W eq. (5.9)) computed once through kernel.contract_gradient.
/// `kernel` gives the form; its own values are not used (a copy takes p's).
LogMarginal log_marginal_likelihood(const Kernel& kernel, const Vec& log_params, const Mat& X, const Vec& r,
                                    bool with_gradient);

/// Independent log-normal priors on ℓ_d, σ_f, σ_n (Kuindersma 2013, eq. (13)), in standardized units. The
/// lengthscale and signal_std priors reach the kernel as its role defaults (Kernel::set_role_defaults), which
/// then owns the prior of its parameters.
struct HyperPriors {
  bool enabled = true;
  LogNormalPrior lengthscale{std::log(0.5), 1.0};
  LogNormalPrior signal_std{0.0, 1.0};
  // Wide (sd 3 in log) so that the data decide between deterministic and noisy costs: with sd 1.5 Ackley-5's
  // upper-quartile regret was 0.41 against 0.16 (README); noisy robot costs are dominated by the likelihood either way.
  LogNormalPrior noise_std{std::log(1e-2), 3.0};
  /// The kernel's log prior on p[0..m) plus the noise prior on p[m]; 0 with zero gradient when disabled.
  double log_density(const Kernel& kernel, const Vec& log_params, Vec* grad) const;
};

/// The fit objective: log marginal likelihood + log hyperprior − a quadratic penalty outside `box`
/// (so that optimizers that ignore the box, like ceres_lbfgs, are still pulled back to it). Thread-safe.
class LogPosterior final : public DifferentiableFunction {
 public:
  LogPosterior(const Kernel& kernel, Mat X, Vec r, HyperPriors priors, Box box);
  Index dim() const override { return kernel_->num_params() + 1; }
  double value(const Vec& p, Vec* grad) const override;

 private:
  std::shared_ptr<const Kernel> kernel_;
  Mat X_;
  Vec r_;
  HyperPriors priors_;
  Box box_;
};

}  // namespace varbo::gp
