#include "kernel.hpp"

#include <cmath>
#include <stdexcept>

namespace varbo::kernels {

namespace {

// Every quantity below is written in terms of the scaled squared distance r² and two functions of it:
//   ρ(r²)        the correlation, k = σ² ρ
//   ρ'(r²)       dρ/d(r²), so that ∂k/∂log ℓ_d = σ² ρ' · (−2 s_d) with s_d = (x_d − x'_d)²/ℓ_d²
//                and ∂k/∂x_d = σ² ρ' · 2 (x_d − x'_d)/ℓ_d².
// Writing Matérn-5/2 through dρ/d(r²) removes the 1/r of dρ/dr, so coincident points need no special case.
// Matérn-1/2 is the exception: dρ/d(r²) = −e^{−r}/(2r) is unbounded at r = 0, where it only ever multiplies a
// zero difference; it is set to 0 there (a subgradient for ∂k/∂x, the exact value for ∂k/∂log ℓ).
constexpr double kSqrt5 = 2.23606797749978969641;
constexpr double kSqrt3 = 1.73205080756887729353;

inline double correlation(KernelType type, double r2) {
  if (type == KernelType::SquaredExponential) return std::exp(-0.5 * r2);  // Rasmussen & Williams eq. (4.9)
  const double r = std::sqrt(r2);
  if (type == KernelType::Matern12) return std::exp(-r);                    // R&W eq. (4.14) with ν = 1/2
  if (type == KernelType::Matern32) return (1.0 + kSqrt3 * r) * std::exp(-kSqrt3 * r);  // R&W eq. (4.17), ν = 3/2
  return (1.0 + kSqrt5 * r + (5.0 / 3.0) * r2) * std::exp(-kSqrt5 * r);   // R&W eq. (4.17), ν = 5/2
}

/// dρ/d(r²) at r = 0 (0 for Matérn-1/2, see above).
inline double slope_at_zero(KernelType type) {
  switch (type) {
    case KernelType::SquaredExponential: return -0.5;
    case KernelType::Matern52: return -5.0 / 6.0;
    case KernelType::Matern32: return -1.5;
    case KernelType::Matern12: return 0.0;
  }
  return 0.0;
}

/// ρ and dρ/d(r²) together (one exp).
inline void correlation_and_slope(KernelType type, double r2, double& rho, double& slope) {
  if (type == KernelType::SquaredExponential) {
    rho = std::exp(-0.5 * r2);
    slope = -0.5 * rho;
    return;
  }
  const double r = std::sqrt(r2);
  if (type == KernelType::Matern12) {
    rho = std::exp(-r);
    slope = r > 0.0 ? -0.5 * rho / r : 0.0;
    return;
  }
  if (type == KernelType::Matern32) {
    const double e = std::exp(-kSqrt3 * r);
    rho = (1.0 + kSqrt3 * r) * e;
    slope = -1.5 * e;  // dρ/dr = −3 r e^{−√3 r}
    return;
  }
  const double e = std::exp(-kSqrt5 * r);
  rho = (1.0 + kSqrt5 * r + (5.0 / 3.0) * r2) * e;
  // dρ/dr = −(5/3) r (1 + √5 r) e^{−√5 r};  dρ/d(r²) = dρ/dr / (2r)
  slope = -(5.0 / 6.0) * (1.0 + kSqrt5 * r) * e;
}

/// Rows of X divided by the lengthscales.
Mat scaled(const Mat& X, const Vec& inv_ell) { return X * inv_ell.asDiagonal(); }

/// Squared distances between rows, computed by explicit differences (exact zero for duplicated points).
Mat squared_distances(const Mat& A, const Mat& B) {
  Mat R(A.rows(), B.rows());
  for (Index j = 0; j < B.rows(); ++j)
    for (Index i = 0; i < A.rows(); ++i) R(i, j) = (A.row(i) - B.row(j)).squaredNorm();
  return R;
}

Mat squared_distances_sym(const Mat& A) {
  const Index n = A.rows();
  Mat R(n, n);
  for (Index j = 0; j < n; ++j) {
    R(j, j) = 0.0;
    for (Index i = j + 1; i < n; ++i) R(i, j) = R(j, i) = (A.row(i) - A.row(j)).squaredNorm();
  }
  return R;
}

}  // namespace

KernelType parse_kernel_type(const std::string& name) {
  if (name == "se_ard") return KernelType::SquaredExponential;
  if (name == "matern52_ard") return KernelType::Matern52;
  if (name == "matern32_ard") return KernelType::Matern32;
  if (name == "matern12_ard") return KernelType::Matern12;
  throw std::invalid_argument("unknown kernel '" + name +
                              "' (expected se_ard, matern12_ard, matern32_ard or matern52_ard)");
}

std::string kernel_type_name(KernelType type) {
  switch (type) {
    case KernelType::SquaredExponential: return "se_ard";
    case KernelType::Matern52: return "matern52_ard";
    case KernelType::Matern32: return "matern32_ard";
    case KernelType::Matern12: return "matern12_ard";
  }
  return "?";
}

ArdKernel::ArdKernel(KernelType type, Index dim) : type_(type), dim_(dim), log_params_(Vec::Zero(dim + 1)) {
  if (dim < 1) throw std::invalid_argument("ArdKernel: dimension must be at least 1");
}

void ArdKernel::set_log_params(const Vec& p) {
  if (p.size() != num_params())
    throw std::invalid_argument("ArdKernel::set_log_params: expected " + std::to_string(num_params()) +
                                " values, got " + std::to_string(p.size()));
  log_params_ = p;
}

Vec ArdKernel::lengthscales() const { return log_params_.head(dim_).array().exp(); }

double ArdKernel::variance() const { return std::exp(2.0 * log_params_(dim_)); }

Mat ArdKernel::matrix(const Mat& X) const {
  const Vec inv_ell = (-log_params_.head(dim_)).array().exp();
  const double s2 = variance();
  Mat K = squared_distances_sym(scaled(X, inv_ell));
  const Index n = K.rows();
  for (Index j = 0; j < n; ++j) {
    K(j, j) = s2;
    for (Index i = j + 1; i < n; ++i) K(i, j) = K(j, i) = s2 * correlation(type_, K(i, j));
  }
  return K;
}

Mat ArdKernel::cross(const Mat& X, const Mat& Z) const {
  const Vec inv_ell = (-log_params_.head(dim_)).array().exp();
  const double s2 = variance();
  Mat K = squared_distances(scaled(X, inv_ell), scaled(Z, inv_ell));
  for (Index j = 0; j < K.cols(); ++j)
    for (Index i = 0; i < K.rows(); ++i) K(i, j) = s2 * correlation(type_, K(i, j));
  return K;
}

Vec ArdKernel::cross_vec(const Vec& x, const Mat& X) const {
  const Vec inv_ell = (-log_params_.head(dim_)).array().exp();
  const double s2 = variance();
  const Eigen::RowVectorXd xs = (x.array() * inv_ell.array()).matrix().transpose();
  Vec k(X.rows());
  for (Index i = 0; i < X.rows(); ++i) {
    const double r2 = (X.row(i).cwiseProduct(inv_ell.transpose()) - xs).squaredNorm();
    k(i) = s2 * correlation(type_, r2);
  }
  return k;
}

Vec ArdKernel::contract_gradient(const Mat& X, const Mat& W) const {
  const Index n = X.rows();
  const Vec inv_ell = (-log_params_.head(dim_)).array().exp();
  const double s2 = variance();
  const Mat A = scaled(X, inv_ell);  // a_id = x_id / ℓ_d
  if (type_ == KernelType::Matern12) return contract_gradient_direct(A, W);
  // M_ik = W_ik σ² ρ'(r²_ik) (symmetric);  trace term Σ W∘K for log σ.
  Mat M(n, n);
  double wk = 0.0;
  for (Index j = 0; j < n; ++j) {
    M(j, j) = W(j, j) * s2 * slope_at_zero(type_);
    wk += W(j, j) * s2;
    for (Index i = j + 1; i < n; ++i) {
      double rho, slope;
      correlation_and_slope(type_, (A.row(i) - A.row(j)).squaredNorm(), rho, slope);
      const double w = 0.5 * (W(i, j) + W(j, i));
      M(i, j) = M(j, i) = w * s2 * slope;
      wk += 2.0 * w * s2 * rho;
    }
  }
  // g_d = ½ Σ_ik W_ik ∂K_ik/∂log ℓ_d = −Σ_ik M_ik (a_id − a_kd)²
  //     = −(2 Σ_i a_id² (M 1)_i − 2 a_d' M a_d)   (M symmetric): one GEMM instead of N² D loops.
  const Vec row_sums = M.rowwise().sum();
  const Mat MA = M * A;
  Vec g(num_params());
  for (Index d = 0; d < dim_; ++d) {
    const double quad = A.col(d).dot(MA.col(d));
    const double diag = A.col(d).array().square().matrix().dot(row_sums);
    g(d) = -2.0 * (diag - quad);
  }
  // ∂K/∂log σ = 2K, so g_σ = ½ Σ W∘2K = Σ W∘K.
  g(dim_) = wk;
  return g;
}

Vec ArdKernel::contract_gradient_direct(const Mat& A, const Mat& W) const {
  // Pair by pair: the fast form below cancels Σ a² M against a'Ma, which loses every digit when M_ik ~ 1/r_ik
  // is huge for nearly coincident points (Matérn-1/2).
  const Index n = A.rows();
  const double s2 = variance();
  Vec g = Vec::Zero(num_params());
  for (Index j = 0; j < n; ++j) {
    g(dim_) += W(j, j) * s2;
    for (Index i = j + 1; i < n; ++i) {
      double rho, slope;
      correlation_and_slope(type_, (A.row(i) - A.row(j)).squaredNorm(), rho, slope);
      const double w = W(i, j) + W(j, i);  // ½ (W_ij + W_ji) counted for both (i, j) and (j, i)
      g.head(dim_) -= (w * s2 * slope) * (A.row(i) - A.row(j)).transpose().array().square().matrix();
      g(dim_) += w * s2 * rho;
    }
  }
  return g;
}

std::vector<Mat> ArdKernel::matrix_gradients(const Mat& X) const {
  const Index n = X.rows();
  const Vec inv_ell = (-log_params_.head(dim_)).array().exp();
  const double s2 = variance();
  const Mat A = scaled(X, inv_ell);
  std::vector<Mat> G(num_params(), Mat::Zero(n, n));
  for (Index j = 0; j < n; ++j) {
    for (Index i = 0; i < n; ++i) {
      double rho, slope;
      correlation_and_slope(type_, (A.row(i) - A.row(j)).squaredNorm(), rho, slope);
      for (Index d = 0; d < dim_; ++d) {
        const double diff = A(i, d) - A(j, d);
        G[d](i, j) = s2 * slope * (-2.0 * diff * diff);
      }
      G[dim_](i, j) = 2.0 * s2 * rho;
    }
  }
  return G;
}

Mat ArdKernel::cross_gradient_x(const Vec& x, const Mat& X) const {
  const Vec inv_ell = (-log_params_.head(dim_)).array().exp();
  const Vec inv_ell2 = inv_ell.array().square();
  const double s2 = variance();
  Mat G(dim_, X.rows());
  for (Index i = 0; i < X.rows(); ++i) {
    const Vec diff = x - X.row(i).transpose();
    const double r2 = (diff.array() * inv_ell.array()).square().sum();
    double rho, slope;
    correlation_and_slope(type_, r2, rho, slope);
    G.col(i) = (2.0 * s2 * slope) * (diff.array() * inv_ell2.array()).matrix();
  }
  return G;
}

}  // namespace varbo::kernels
