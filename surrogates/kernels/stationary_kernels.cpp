// se_ard, matern*_ard (through the ArdKernel engine of kernel.cpp) and rational_quadratic.
#include <cmath>

#include "kernel_library.hpp"

namespace varbo::kernels {

namespace {

class StationaryArd final : public Kernel {
 public:
  StationaryArd(KernelType type, Index dim) : engine_(type, dim) {
    std::vector<KernelParameter> p;
    for (Index i = 0; i < dim; ++i) p.push_back(lengthscale_parameter(i));
    p.push_back(amplitude_parameter());
    declare(std::move(p));
  }
  std::unique_ptr<Kernel> clone() const override { return std::make_unique<StationaryArd>(*this); }
  Index dim() const override { return engine_.dim(); }
  Mat matrix(const Mat& X) const override { return engine_.matrix(X); }
  Mat cross(const Mat& X, const Mat& Z) const override { return engine_.cross(X, Z); }
  Vec cross_vec(const Vec& x, const Mat& X) const override { return engine_.cross_vec(x, X); }
  double diagonal(const Vec&) const override { return engine_.variance(); }
  Vec contract_gradient(const Mat& X, const Mat& W) const override { return engine_.contract_gradient(X, W); }
  std::vector<Mat> matrix_gradients(const Mat& X) const override { return engine_.matrix_gradients(X); }
  Mat cross_gradient_x(const Vec& x, const Mat& X) const override { return engine_.cross_gradient_x(x, X); }

 private:
  void params_changed() override { engine_.set_log_params(log_params()); }
  ArdKernel engine_;
};

/// k = σ² (1 + r²/(2α))^{−α} (R&W eq. 4.19); α → ∞ gives SE. With u = r²/(2α):
///   dρ/d(r²) = −½ (1 + u)^{−α−1},   ∂ρ/∂log α = ρ α (u/(1 + u) − log(1 + u)).
class RationalQuadratic final : public Kernel {
 public:
  explicit RationalQuadratic(Index dim) : dim_(dim) {
    std::vector<KernelParameter> p;
    for (Index i = 0; i < dim; ++i) p.push_back(lengthscale_parameter(i));
    p.push_back(amplitude_parameter());
    p.push_back({"alpha", KernelParameterRole::Shape, {0.0, 1.5}, 1e-2, 1e3, false});
    declare(std::move(p));
  }
  std::unique_ptr<Kernel> clone() const override { return std::make_unique<RationalQuadratic>(*this); }
  Index dim() const override { return dim_; }

  Mat matrix(const Mat& X) const override { return cross(X, X); }
  Mat cross(const Mat& X, const Mat& Z) const override {
    const Mat A = X * inv_ell_.asDiagonal(), B = Z * inv_ell_.asDiagonal();
    Mat K(X.rows(), Z.rows());
    for (Index j = 0; j < Z.rows(); ++j)
      for (Index i = 0; i < X.rows(); ++i) K(i, j) = s2_ * rho((A.row(i) - B.row(j)).squaredNorm());
    return K;
  }
  double diagonal(const Vec&) const override { return s2_; }

  Vec contract_gradient(const Mat& X, const Mat& W) const override {
    const Index n = X.rows();
    const Mat A = X * inv_ell_.asDiagonal();
    Vec g = Vec::Zero(num_params());
    for (Index j = 0; j < n; ++j) {
      g(dim_) += W(j, j) * s2_;
      for (Index i = j + 1; i < n; ++i) {
        const Eigen::RowVectorXd diff = A.row(i) - A.row(j);
        const Terms t = terms(diff.squaredNorm());
        const double w = W(i, j) + W(j, i);  // both (i, j) and (j, i), times ½
        g.head(dim_) -= (w * s2_ * t.slope) * diff.transpose().array().square().matrix();
        g(dim_) += w * s2_ * t.rho;
        g(dim_ + 1) += 0.5 * w * s2_ * t.d_log_alpha;
      }
    }
    return g;
  }
  std::vector<Mat> matrix_gradients(const Mat& X) const override {
    const Index n = X.rows();
    const Mat A = X * inv_ell_.asDiagonal();
    std::vector<Mat> G(static_cast<std::size_t>(num_params()), Mat::Zero(n, n));
    for (Index j = 0; j < n; ++j)
      for (Index i = 0; i < n; ++i) {
        const Eigen::RowVectorXd diff = A.row(i) - A.row(j);
        const Terms t = terms(diff.squaredNorm());
        for (Index d = 0; d < dim_; ++d) G[static_cast<std::size_t>(d)](i, j) = -2.0 * s2_ * t.slope * diff(d) * diff(d);
        G[static_cast<std::size_t>(dim_)](i, j) = 2.0 * s2_ * t.rho;
        G[static_cast<std::size_t>(dim_ + 1)](i, j) = s2_ * t.d_log_alpha;
      }
    return G;
  }
  Mat cross_gradient_x(const Vec& x, const Mat& X) const override {
    const Vec inv_ell2 = inv_ell_.array().square();
    Mat G(dim_, X.rows());
    for (Index i = 0; i < X.rows(); ++i) {
      const Vec diff = x - X.row(i).transpose();
      const Terms t = terms((diff.array() * inv_ell_.array()).square().sum());
      G.col(i) = (2.0 * s2_ * t.slope) * (diff.array() * inv_ell2.array()).matrix();
    }
    return G;
  }

 private:
  struct Terms {
    double rho, slope, d_log_alpha;
  };
  double rho(double r2) const { return std::pow(1.0 + r2 / (2.0 * alpha_), -alpha_); }
  Terms terms(double r2) const {
    const double u = r2 / (2.0 * alpha_);
    const double rho = std::pow(1.0 + u, -alpha_);
    return {rho, -0.5 * rho / (1.0 + u), rho * alpha_ * (u / (1.0 + u) - std::log1p(u))};
  }
  void params_changed() override {
    inv_ell_ = (-log_params().head(dim_)).array().exp();
    s2_ = std::exp(2.0 * log_params()(dim_));
    alpha_ = std::exp(log_params()(dim_ + 1));
  }
  Index dim_;
  Vec inv_ell_;
  double s2_ = 1, alpha_ = 1;
};

}  // namespace

std::unique_ptr<Kernel> make_stationary_ard(KernelType type, Index dim) {
  if (dim < 1) throw std::invalid_argument("kernel: dimension must be at least 1");
  return std::make_unique<StationaryArd>(type, dim);
}

std::unique_ptr<Kernel> make_rational_quadratic(Index dim) {
  if (dim < 1) throw std::invalid_argument("rational_quadratic: dimension must be at least 1");
  return std::make_unique<RationalQuadratic>(dim);
}

}  // namespace varbo::kernels
