#pragma once
// The marginal variational (MV) bound of the variational heteroscedastic GP and its analytic gradient
// (Lázaro-Gredilla & Titsias 2011; Kuindersma et al. 2013, eq. 6), evaluated in the numerically stable order
// of the authors' vhgpr.m (design note vhgp.md, sections 3–5). Works in "model units": y as given (the
// surrogate standardizes before it calls this), X as given (the unit cube inside the framework).
//
//   y_i = f(x_i) + ε_i,  ε_i ~ N(0, exp(g(x_i))),  f ~ GP(0, k_f),  g ~ GP(μ0, k_g)
//   q(g) = N(μ, Σ),  Σ = (K_g⁻¹ + Λ)⁻¹,  μ = K_g(Λ − ½)1 + μ0 1
//   F = log N(y | 0, K_f + R) − KL(N(μ, Σ) ‖ N(μ0 1, K_g)) − ¼ tr Σ,   R_ii = exp(μ_i − Σ_ii/2)
#include <memory>
#include <string>
#include "vhgp_kernels.hpp"
#include "vhgp_params.hpp"

namespace varbo::vhgp {

struct BoundValue {
  bool ok = false;        ///< false: a Cholesky factorization failed or F is not finite
  double F = 0;           ///< the bound (to maximize)
  VhgpGradient gradient;  ///< filled when asked for and ok
  std::string error;
};

/// F(Λ, θ) and ∂F on fixed data, for any pair of kernels. Thread-safe (evaluate is const, allocates its own
/// work space and evaluates its own copies of the kernels).
class VhgpBound {
 public:
  /// Builds both kernels for the dimension of X (std::invalid_argument when a kernel cannot be built for it).
  VhgpBound(Mat X, Vec y, const VhgpKernels& kernels);
  Index size() const { return y_.size(); }
  Index dim() const { return X_.cols(); }
  /// The kernels' forms: parameter tables in the order of θ_f and θ_g (their own values are not used).
  const Kernel& f_form() const { return *f_; }
  const Kernel& g_form() const { return *g_; }
  Index num_f() const { return f_->num_params(); }
  Index num_g() const { return g_->num_params(); }
  Index num_params() const { return size() + num_f() + num_g() + 1; }
  double jitter() const { return jitter_; }
  /// VhgpParams::unpack for this data and these kernels.
  VhgpParams unpack(const Vec& packed) const { return VhgpParams::unpack(packed, size(), num_f(), num_g()); }
  const Mat& X() const { return X_; }
  const Vec& y() const { return y_; }
  BoundValue evaluate(const VhgpParams& params, bool with_gradient) const;

 private:
  Mat X_;
  Vec y_;
  std::shared_ptr<const Kernel> f_, g_;
  double jitter_;
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
  JitteredKernel kf_, kg_;
  Vec alpha_, sc_, beta_, mu_, sigma_diag_;
  Mat chol_a_;   ///< lower L with L L' = S(K_f + R)S
  Mat cinv_bs_;  ///< L_B⁻¹ Λ^{½} (lower triangular)
};

}  // namespace varbo::vhgp
