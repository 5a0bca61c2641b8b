// linear, constant and white: kernels without lengthscales, whose only hyperparameter is an amplitude.
#include <cmath>

#include "kernel_library.hpp"

namespace varbo::kernels {

namespace {

/// Shared by the three: one log-σ parameter, k = σ² κ(x, x') with κ free of hyperparameters, so ∂K/∂log σ = 2K.
class AmplitudeOnly : public Kernel {
 public:
  AmplitudeOnly(Index dim, KernelParameter p) : dim_(dim) { declare({std::move(p)}); }
  Index dim() const override { return dim_; }
  Vec contract_gradient(const Mat& X, const Mat& W) const override {
    return Vec::Constant(1, (W.array() * matrix(X).array()).sum());  // ½ Σ W∘2K
  }
  std::vector<Mat> matrix_gradients(const Mat& X) const override { return {2.0 * matrix(X)}; }

 protected:
  double s2() const { return std::exp(2.0 * log_params()(0)); }
  Index dim_;
};

class Linear final : public AmplitudeOnly {
 public:
  explicit Linear(Index dim) : AmplitudeOnly(dim, amplitude_parameter()) {}
  std::unique_ptr<Kernel> clone() const override { return std::make_unique<Linear>(*this); }
  Mat matrix(const Mat& X) const override { return s2() * X * X.transpose(); }
  Mat cross(const Mat& X, const Mat& Z) const override { return s2() * X * Z.transpose(); }
  double diagonal(const Vec& x) const override { return s2() * x.squaredNorm(); }
  Mat cross_gradient_x(const Vec&, const Mat& X) const override { return s2() * X.transpose(); }
};

class Constant final : public AmplitudeOnly {
 public:
  explicit Constant(Index dim) : AmplitudeOnly(dim, amplitude_parameter()) {}
  std::unique_ptr<Kernel> clone() const override { return std::make_unique<Constant>(*this); }
  Mat matrix(const Mat& X) const override { return Mat::Constant(X.rows(), X.rows(), s2()); }
  Mat cross(const Mat& X, const Mat& Z) const override { return Mat::Constant(X.rows(), Z.rows(), s2()); }
  double diagonal(const Vec&) const override { return s2(); }
  Mat cross_gradient_x(const Vec&, const Mat& X) const override { return Mat::Zero(dim_, X.rows()); }
};

/// Independent noise on each training point (by index, not by equal coordinates) and on the test point's own
/// variance; nothing between a test point and the data (GPML's covNoise; Lázaro-Gredilla & Titsias 2011 add it to
/// the kernel of g).
class White final : public AmplitudeOnly {
 public:
  explicit White(Index dim) : AmplitudeOnly(dim, noise_parameter()) {}
  std::unique_ptr<Kernel> clone() const override { return std::make_unique<White>(*this); }
  Mat matrix(const Mat& X) const override { return s2() * Mat::Identity(X.rows(), X.rows()); }
  Mat cross(const Mat& X, const Mat& Z) const override { return Mat::Zero(X.rows(), Z.rows()); }
  double diagonal(const Vec&) const override { return s2(); }
  Mat cross_gradient_x(const Vec&, const Mat& X) const override { return Mat::Zero(dim_, X.rows()); }
};

}  // namespace

std::unique_ptr<Kernel> make_linear(Index dim) { return std::make_unique<Linear>(dim); }
std::unique_ptr<Kernel> make_constant(Index dim) { return std::make_unique<Constant>(dim); }
std::unique_ptr<Kernel> make_white(Index dim) { return std::make_unique<White>(dim); }

}  // namespace varbo::kernels
