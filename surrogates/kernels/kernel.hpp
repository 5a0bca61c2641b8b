#pragma once
// Stationary ARD covariance functions: the computational engine of the se_ard and matern*_ard kernel components
// (kernel_components.hpp), also used directly by the VHGP bound and bo's feasibility model.
// k(x, x') = σ² ρ(r),  r² = Σ_d (x_d − x'_d)² / ℓ_d²,  hyperparameters kept in log space:
//   log_params = [log ℓ_1, ..., log ℓ_D, log σ]
#include <functional>
#include <string>
#include "varbo/types.hpp"

namespace varbo::kernels {

enum class KernelType { SquaredExponential, Matern52, Matern12, Matern32 };
/// "se_ard" | "matern12_ard" | "matern32_ard" | "matern52_ard" (throws std::invalid_argument otherwise).
KernelType parse_kernel_type(const std::string& name);
std::string kernel_type_name(KernelType type);

class ArdKernel {
 public:
  ArdKernel(KernelType type, Index dim);
  KernelType type() const { return type_; }
  Index dim() const { return dim_; }
  Index num_params() const { return dim_ + 1; }
  const Vec& log_params() const { return log_params_; }
  void set_log_params(const Vec& p);
  Vec lengthscales() const;
  double variance() const;  ///< σ² = k(x, x)

  Mat matrix(const Mat& X) const;                ///< K(X, X), rows of X are points
  Mat cross(const Mat& X, const Mat& Z) const;   ///< K(X, Z)
  Vec cross_vec(const Vec& x, const Mat& X) const;  ///< k(x, X_i) for every row i

  /// g_j = ½ Σ_ik W_ik ∂K_ik/∂log_param_j for symmetric W: the contraction every marginal-likelihood
  /// gradient needs, without forming D+1 full derivative matrices.
  Vec contract_gradient(const Mat& X, const Mat& W) const;
  /// ∂K/∂log_param_j for every j (for tests and for models that need the matrices).
  std::vector<Mat> matrix_gradients(const Mat& X) const;
  /// Column i = ∂k(x, X_i)/∂x  (D × N).
  Mat cross_gradient_x(const Vec& x, const Mat& X) const;

 private:
  Vec contract_gradient_direct(const Mat& A, const Mat& W) const;
  KernelType type_;
  Index dim_;
  Vec log_params_;
};

}  // namespace varbo::kernels
