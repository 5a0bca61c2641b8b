#pragma once
// The two covariance functions of the VHGP — k_f of the cost, k_g of the log noise variance — as any
// varbo::Kernel: a built-in ARD kernel, a rational quadratic, or a sum or product such as the original authors'
// defaults (Lázaro-Gredilla & Titsias 2011 code, vhgp.md §2): f: SE + constant, g: SE + white noise.
//
// The bound sees a kernel only through its parameter table (names, roles, priors, boxes; log values) and four
// operations: the training matrix, the contraction ½ Σ W ∘ ∂K/∂θ, the cross-covariance and its x-gradient. This
// file adds what the VHGP needs on top: the relative jitter of GPML's covSEisoj, and the conventions that used to
// assume one ARD kernel laid out as [log ℓ_1..D, log σ] — hyperparameter names (`lengthscale_f[0]`), cost units,
// start values — written once per role.
#include <functional>
#include <memory>
#include <string>

#include "kernel.hpp"
#include "varbo/kernel.hpp"

namespace varbo::vhgp {

using kernels::KernelType;
/// Builds a kernel for an input dimension (the surrogate learns its dimension at construction).
using KernelMaker = std::function<std::unique_ptr<Kernel>(Index dim)>;

/// A kernel as configured, before the dimension is known: one of the built-in stationary ARD kernels (tests,
/// benches: `cfg.kernels.f = KernelType::SquaredExponential`) or any kernel component (the plugin's `kernel_f:`).
class KernelSpec {
 public:
  KernelSpec(KernelType type);  // NOLINT(google-explicit-constructor): `kernels.f = KernelType::Matern52`
  KernelSpec(KernelMaker make);  // NOLINT(google-explicit-constructor)
  std::unique_ptr<Kernel> build(Index dim) const;

 private:
  KernelMaker make_;
};

/// The kernel pair and the relative jitter. The defaults are those of the plugin's declarations (kernel_f
/// matern52_ard, kernel_g se_ard, jitter 1e-11; plugin.cpp).
struct VhgpKernels {
  KernelSpec f = KernelType::Matern52;
  KernelSpec g = KernelType::SquaredExponential;
  double jitter = 1e-11;  // the authors' 1e-6·σ_f² floored the noise sd at 1e-3·σ_f (docs/noisy.md)
};

/// A kernel at fixed hyperparameters as the bound uses it: K(X, X) + jitter·diag K(X, X) on the training inputs
/// (GPML's covSEisoj adds 1e-6·σ², the diagonal of its SE kernel) and k(x, x)(1 + jitter) at a new input (vhgp.md
/// §2, §6). Holds its own copy of the kernel: evaluations at different θ run in parallel.
class JitteredKernel {
 public:
  JitteredKernel() = default;
  JitteredKernel(const Kernel& form, const Vec& theta, double jitter);
  const Kernel& kernel() const { return *k_; }
  Mat training_matrix(const Mat& X) const;
  /// ½ Σ_ik W_ik ∂(K + jitter·diag K)_ik/∂θ_j for symmetric W: the jitter term moves with θ (for a stationary
  /// kernel only through σ²), which is the contraction of W with jitter·W_ii added on the diagonal.
  Vec contract_gradient(const Mat& X, const Mat& W) const;
  Vec cross_vec(const Vec& x, const Mat& X) const { return k_->checked_cross_vec(x, X); }
  Mat cross_gradient_x(const Vec& x, const Mat& X) const { return k_->checked_cross_gradient_x(x, X); }
  /// k** = k(x, x)(1 + jitter), the prior variance at a new input (a white term included).
  double prior_variance(const Vec& x) const { return k_->diagonal(x) * (1.0 + jitter_); }
  /// ∂k**/∂x = 2 ∂k(x, z)/∂x at z = x (k symmetric); 0 for stationary kernels, 2σ²x for a linear one.
  Vec prior_variance_gradient(const Vec& x) const;

 private:
  std::shared_ptr<const Kernel> k_;
  double jitter_ = 0;
};

/// Which process of the model a kernel belongs to.
enum class Process { F, G };

/// The VHGP's name of a kernel parameter: `_f` or `_g` after its last identifier, so se_ard's `lengthscale[0]`
/// and `signal_std` read `lengthscale_f[0]`, `signal_std_f` (the names of the fixed-kernel vhgp) and a sum's
/// `terms[1].noise_std` reads `terms[1].noise_std_g`.
std::string process_name(const std::string& kernel_name, Process p);

/// d for a per-dimension parameter (a name ending in `lengthscale[d]`), −1 otherwise.
Index dimension_of(const std::string& kernel_name);

/// Log values by role: every lengthscale `log_lengthscale`, every amplitude that carries the output scale
/// `log_amplitude` (the later factors of a product 0, i.e. 1), every noise term `log_noise`, anything else
/// (shape parameters) its prior's median.
Vec values_by_role(const Kernel& form, double log_lengthscale, double log_amplitude, double log_noise);

/// 1 for each parameter whose natural value scales with the costs (KernelParameter::scales_with_output), else 0:
/// the log values of cost units are those of standardized units + log(scale) there. Only f's kernel models
/// costs; g models a log variance, so none of its parameters scale (mu0 shifts by 2 log(scale) instead).
Vec output_scaling(const Kernel& form);

}  // namespace varbo::vhgp
