// Kernel::checked_*: a kernel's results of the wrong shape are a named error, never a read past a matrix.
#include <cmath>
#include <string>

#include "varbo/errors.hpp"
#include "varbo/kernel.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {

/// An isotropic squared-exponential kernel whose methods can be made to return wrong shapes, as a third-party
/// kernel did (red team, session 31: one matrix_gradients() matrix for two hyperparameters crashed varbo and the
/// Python interpreter; a matrix() a row short made a seeded run differ from itself).
class FaultyKernel final : public Kernel {
 public:
  FaultyKernel(Index dim, std::string fault) : dim_(dim), fault_(std::move(fault)) {
    declare({{"lengthscale", KernelParameterRole::Lengthscale, {}, 1e-3, 1e3, false},
             {"signal_std", KernelParameterRole::Amplitude, {}, 1e-3, 1e3, true}});
  }
  std::unique_ptr<Kernel> clone() const override { return std::make_unique<FaultyKernel>(*this); }
  Index dim() const override { return dim_; }
  Mat matrix(const Mat& X) const override {
    const Mat K = cross(X, X);
    return fault_ == "small_matrix" ? Mat(K.topLeftCorner(X.rows() - 1, X.rows() - 1)) : K;
  }
  Mat cross(const Mat& X, const Mat& Z) const override {
    Mat K(X.rows(), Z.rows());
    for (Index i = 0; i < X.rows(); ++i)
      for (Index j = 0; j < Z.rows(); ++j) K(i, j) = std::exp(-0.5 * (X.row(i) - Z.row(j)).squaredNorm());
    return fault_ == "bad_cross" ? Mat(K.leftCols(Z.rows() - 1)) : K;
  }
  double diagonal(const Vec&) const override { return 1.0; }
  std::vector<Mat> matrix_gradients(const Mat& X) const override {
    std::vector<Mat> G(2, Mat::Zero(X.rows(), X.rows()));
    if (fault_ == "few_grads") G.pop_back();
    if (fault_ == "wrong_grad_size") G[1] = Mat::Zero(X.rows() + 1, X.rows());
    return G;
  }
  Mat cross_gradient_x(const Vec& x, const Mat& X) const override {
    return Mat::Zero(x.size(), X.rows() + (fault_ == "bad_cols" ? 50 : 0));
  }

 private:
  Index dim_;
  std::string fault_;
};

}  // namespace

TEST_CASE("checked kernel results: right shapes pass, wrong ones are a PluginCodeError naming the method") {
  const Mat X = Mat::Random(5, 2), Z = Mat::Random(3, 2);
  const Vec x = Vec::Random(2);
  const FaultyKernel good(2, "");
  CHECK(good.checked_matrix(X).rows() == 5);
  CHECK(good.checked_cross(X, Z).cols() == 3);
  CHECK(good.checked_cross_vec(x, X).size() == 5);
  CHECK(good.checked_matrix_gradients(X).size() == 2);
  CHECK(good.checked_cross_gradient_x(x, X).cols() == 5);
  CHECK(good.checked_contract_gradient(X, Mat::Identity(5, 5)).size() == 2);

  CHECK_THROWS_WITH_AS(FaultyKernel(2, "small_matrix").checked_matrix(X),
                       doctest::Contains("matrix() returned a 4×4 matrix where 5×5 was expected"), PluginCodeError);
  CHECK_THROWS_WITH_AS(FaultyKernel(2, "bad_cross").checked_cross(X, Z), doctest::Contains("cross()"), PluginCodeError);
  CHECK_THROWS_WITH_AS(FaultyKernel(2, "bad_cross").checked_cross_vec(x, X), doctest::Contains("5×0 matrix"),
                       PluginCodeError);
  CHECK_THROWS_WITH_AS(FaultyKernel(2, "few_grads").checked_matrix_gradients(X),
                       doctest::Contains("1 matrices where 2 (one per hyperparameter)"), PluginCodeError);
  CHECK_THROWS_WITH_AS(FaultyKernel(2, "wrong_grad_size").checked_matrix_gradients(X),
                       doctest::Contains("6×5 matrix"), PluginCodeError);
  CHECK_THROWS_WITH_AS(FaultyKernel(2, "bad_cols").checked_cross_gradient_x(x, X),
                       doctest::Contains("[lengthscale, signal_std]"), PluginCodeError);
  // The default contract_gradient reads matrix_gradients() through the check: it indexed G[j] for every
  // hyperparameter, past the end of a short list.
  CHECK_THROWS_AS(FaultyKernel(2, "few_grads").contract_gradient(X, Mat::Identity(5, 5)), PluginCodeError);
}
