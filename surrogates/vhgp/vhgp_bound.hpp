#pragma once
// The marginal variational (MV) bound of the variational heteroscedastic GP and its analytic gradient
// (Lázaro-Gredilla & Titsias 2011; Kuindersma et al. 2013, eq. 6), evaluated in the numerically stable order
// of the authors' vhgpr.m (design note vhgp.md, sections 3–5). Works in "model units": y as given (the
// surrogate standardizes before it calls this), X as given (the unit cube inside the framework).
//
//   y_i = f(x_i) + ε_i,  ε_i ~ N(0, exp(g(x_i))),  f ~ GP(0, k_f),  g ~ GP(μ0, k_g)
//   q(g) = N(μ, Σ),  Σ = (K_g⁻¹ + Λ)⁻¹,  μ = K_g(Λ − ½)1 + μ0 1
//   F = log N(y | 0, K_f + R) − KL(N(μ, Σ) ‖ N(μ0 1, K_g)) − ¼ tr Σ,   R_ii = exp(μ_i − Σ_ii/2)
#include <string>
#include "kernel.hpp"
#include "vhgp_params.hpp"

namespace varbo::vhgp {

using kernels::ArdKernel;
using kernels::KernelType;

/// The kernel pair and the relative jitter: each training covariance gets jitter·σ² on its diagonal and the
/// prior variance at a test point is σ²(1 + jitter), as GPML's covSEisoj (vhgp.md, section 2).
struct VhgpKernels {
  KernelType f = KernelType::SquaredExponential;
  KernelType g = KernelType::SquaredExponential;
  double jitter = 1e-11;  // the authors' 1e-6·σ_f² floored the noise sd at 1e-3·σ_f (docs/noisy.md)
};

struct BoundValue {
  bool ok = false;        ///< false: a Cholesky factorization failed or F is not finite
  double F = 0;           ///< the bound (to maximize)
  VhgpGradient gradient;  ///< filled when asked for and ok
  std::string error;
};

/// F(Λ, θ) and ∂F on fixed data. Thread-safe (evaluate is const and allocates its own work space).
class VhgpBound {
 public:
  VhgpBound(Mat X, Vec y, VhgpKernels kernels);
  Index size() const { return y_.size(); }
  Index dim() const { return X_.cols(); }
  Index num_params() const { return size() + 2 * (dim() + 1) + 1; }
  const Mat& X() const { return X_; }
  const Vec& y() const { return y_; }
  const VhgpKernels& kernels() const { return kernels_; }
  BoundValue evaluate(const VhgpParams& params, bool with_gradient) const;

 private:
  Mat X_;
  Vec y_;
  VhgpKernels kernels_;
};

/// The four latent predictive quantities of vhgp.md section 6 at one test input, and their x-gradients.
struct LatentPrediction {
  double a = 0;   ///< a*    = k_f*'(K_f + R)⁻¹ y
  double c2 = 0;  ///< c*²   = k_f** − k_f*'(K_f + R)⁻¹ k_f*
  double mu = 0;  ///< μ*    = k_g*'(Λ − ½) + μ0
  double s2 = 0;  ///< σ*²   = k_g** − k_g*'(K_g + Λ⁻¹)⁻¹ k_g*
  Vec d_a, d_c2, d_mu, d_s2;
};

/// The model conditioned at fixed parameters: holds the factors the predictive needs. Immutable, thread-safe.
class VhgpPosterior {
 public:
  /// Factorizes at `params`. On failure returns ok = false in *result (and a default-constructed posterior).
  static VhgpPosterior condition(const VhgpBound& bound, const VhgpParams& params, BoundValue* result);
  bool valid() const { return valid_; }
  LatentPrediction predict(const Vec& x, bool with_gradient) const;
  const VhgpParams& params() const { return params_; }
  /// Mean μ and diagonal of Σ of q(g) at the training inputs (for inspection).
  const Vec& q_mean() const { return mu_; }
  const Vec& q_var() const { return sigma_diag_; }

 private:
  bool valid_ = false;
  Mat X_;
  VhgpParams params_;
  ArdKernel kf_{KernelType::SquaredExponential, 1};
  ArdKernel kg_{KernelType::SquaredExponential, 1};
  double kss_f_ = 0, kss_g_ = 0;
  Vec alpha_, sc_, beta_, mu_, sigma_diag_;
  Mat chol_a_;   ///< lower L with L L' = S(K_f + R)S
  Mat cinv_bs_;  ///< L_B⁻¹ Λ^{½} (lower triangular)
};

}  // namespace varbo::vhgp
