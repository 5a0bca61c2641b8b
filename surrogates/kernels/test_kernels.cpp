// Kernel values against closed forms and every gradient against finite differences.
#include <Eigen/Eigenvalues>
#include <cmath>

#include "kernel.hpp"
#include "varbo/function.hpp"
#include "varbo_test.hpp"

using namespace varbo;
using namespace varbo::kernels;

namespace {

Mat random_points(Index n, Index d, std::uint64_t seed) {
  Rng rng(seed);
  Mat X(n, d);
  for (Index i = 0; i < n; ++i) X.row(i) = rng.uniform_vec(d).transpose();
  return X;
}

ArdKernel make_kernel(KernelType type, Index d, std::uint64_t seed) {
  Rng rng(seed);
  ArdKernel k(type, d);
  Vec p(d + 1);
  for (Index j = 0; j < d; ++j) p(j) = std::log(rng.uniform(0.2, 1.0));
  p(d) = std::log(rng.uniform(0.5, 2.0));
  k.set_log_params(p);
  return k;
}

const KernelType kTypes[] = {KernelType::SquaredExponential, KernelType::Matern52};

}  // namespace

TEST_CASE("kernel names parse and round-trip") {
  CHECK(parse_kernel_type("se_ard") == KernelType::SquaredExponential);
  CHECK(parse_kernel_type("matern52_ard") == KernelType::Matern52);
  CHECK(kernel_type_name(parse_kernel_type("matern52_ard")) == "matern52_ard");
  CHECK_THROWS_AS(parse_kernel_type("rbf"), std::invalid_argument);
  ArdKernel k(KernelType::SquaredExponential, 2);
  CHECK_THROWS_AS(k.set_log_params(Vec::Zero(2)), std::invalid_argument);
}

TEST_CASE("closed-form kernel values") {
  // x = (0, 0), x' = (0.3, 0.4), ℓ = (0.5, 2), σ = 1.5:  r² = 0.36 + 0.04 = 0.4
  Vec p(3);
  p << std::log(0.5), std::log(2.0), std::log(1.5);
  Mat X(2, 2);
  X << 0.0, 0.0, 0.3, 0.4;
  const double r2 = 0.4, r = std::sqrt(r2), s2 = 2.25;
  SUBCASE("SE: σ² exp(−r²/2)") {
    ArdKernel k(KernelType::SquaredExponential, 2);
    k.set_log_params(p);
    const Mat K = k.matrix(X);
    CHECK(K(0, 0) == doctest::Approx(s2).epsilon(1e-15));
    CHECK(K(0, 1) == doctest::Approx(s2 * std::exp(-0.5 * r2)).epsilon(1e-14));
    CHECK(k.variance() == doctest::Approx(s2));
  }
  SUBCASE("Matérn-5/2: σ² (1 + √5 r + 5r²/3) exp(−√5 r)") {
    ArdKernel k(KernelType::Matern52, 2);
    k.set_log_params(p);
    const Mat K = k.matrix(X);
    const double expected = s2 * (1 + std::sqrt(5.0) * r + 5.0 * r2 / 3.0) * std::exp(-std::sqrt(5.0) * r);
    CHECK(K(0, 1) == doctest::Approx(expected).epsilon(1e-14));
    CHECK(K(1, 1) == doctest::Approx(s2).epsilon(1e-15));
  }
  ArdKernel k(KernelType::SquaredExponential, 2);
  k.set_log_params(p);
  CHECK(k.lengthscales()(0) == doctest::Approx(0.5));
  CHECK(k.lengthscales()(1) == doctest::Approx(2.0));
}

TEST_CASE("matrix, cross and cross_vec agree; K is symmetric and PSD") {
  for (KernelType type : kTypes) {
    CAPTURE(kernel_type_name(type));
    const ArdKernel k = make_kernel(type, 3, 7);
    const Mat X = random_points(25, 3, 11);
    const Mat Z = random_points(4, 3, 12);
    const Mat K = k.matrix(X);
    CHECK((K - K.transpose()).cwiseAbs().maxCoeff() == 0.0);
    CHECK((K - k.cross(X, X)).cwiseAbs().maxCoeff() < 1e-14);
    const Eigen::SelfAdjointEigenSolver<Mat> es(K);
    // Smallest eigenvalue non-negative up to round-off relative to the largest.
    CHECK(es.eigenvalues().minCoeff() > -1e-12 * es.eigenvalues().maxCoeff());
    const Mat KXZ = k.cross(X, Z);
    for (Index j = 0; j < Z.rows(); ++j)
      CHECK((k.cross_vec(Z.row(j).transpose(), X) - KXZ.col(j)).cwiseAbs().maxCoeff() < 1e-14);
  }
}

TEST_CASE("matrix_gradients match finite differences of matrix()") {
  // Central differences with h = 1e-6 in log space; tolerance 1e-7 absolute on entries of size ~σ² ≤ 4.
  for (KernelType type : kTypes) {
    CAPTURE(kernel_type_name(type));
    ArdKernel k = make_kernel(type, 3, 3);
    const Mat X = random_points(8, 3, 4);
    const auto G = k.matrix_gradients(X);
    const Vec p0 = k.log_params();
    const double h = 1e-6;
    for (Index j = 0; j < k.num_params(); ++j) {
      Vec p = p0;
      p(j) += h;
      k.set_log_params(p);
      const Mat Kp = k.matrix(X);
      p(j) -= 2 * h;
      k.set_log_params(p);
      const Mat Km = k.matrix(X);
      k.set_log_params(p0);
      const Mat fd = (Kp - Km) / (2 * h);
      CAPTURE(j);
      CHECK((fd - G[j]).cwiseAbs().maxCoeff() < 1e-7);
    }
  }
}

TEST_CASE("contract_gradient equals ½ Σ W∘∂K and the FD of ½ Σ W∘K") {
  // Three routes must agree: contraction (fast path), explicit matrices, finite differences.
  // Tolerances: 1e-10 relative between the two analytic routes; check_gradient's 1e-6 relative for FD.
  for (KernelType type : kTypes) {
    CAPTURE(kernel_type_name(type));
    ArdKernel k = make_kernel(type, 4, 21);
    Mat X = random_points(12, 4, 22);
    X.row(5) = X.row(2);  // a duplicated point (r = 0) must not upset Matérn
    Mat W = random_points(12, 12, 23).array() - 0.5;
    W = (W + W.transpose()).eval();
    const Vec g = k.contract_gradient(X, W);
    const auto G = k.matrix_gradients(X);
    for (Index j = 0; j < k.num_params(); ++j) {
      const double direct = 0.5 * (W.array() * G[j].array()).sum();
      CAPTURE(j);
      CHECK(g(j) == doctest::Approx(direct).epsilon(1e-10));
    }
    const Vec p0 = k.log_params();
    FunctionRef f(k.num_params(), [&](const Vec& p, Vec* grad) {
      ArdKernel kk(type, 4);
      kk.set_log_params(p);
      if (grad) *grad = kk.contract_gradient(X, W);
      return 0.5 * (W.array() * kk.matrix(X).array()).sum();
    });
    const GradientCheck c = check_gradient(f, p0);
    CAPTURE(c.analytic.transpose());
    CAPTURE(c.numeric.transpose());
    CHECK(c.max_rel_error < 1e-6);
  }
}

TEST_CASE("cross_gradient_x matches finite differences") {
  // check_gradient on each k(x, X_i); tolerance 1e-6 relative (floor 1e-8).
  for (KernelType type : kTypes) {
    CAPTURE(kernel_type_name(type));
    const ArdKernel k = make_kernel(type, 3, 31);
    const Mat X = random_points(6, 3, 32);
    const Vec x = random_points(1, 3, 33).row(0).transpose();
    const Mat G = k.cross_gradient_x(x, X);
    REQUIRE(G.rows() == 3);
    REQUIRE(G.cols() == 6);
    for (Index i = 0; i < X.rows(); ++i) {
      FunctionRef f(3, [&](const Vec& z, Vec* grad) {
        if (grad) *grad = k.cross_gradient_x(z, X).col(i);
        return k.cross_vec(z, X)(i);
      });
      const GradientCheck c = check_gradient(f, x);
      CAPTURE(i);
      CHECK(c.max_rel_error < 1e-6);
    }
    // At a data point the gradient of k(x, x_i) wrt x vanishes (stationary kernel maximum).
    const Mat G0 = k.cross_gradient_x(X.row(2).transpose(), X);
    CHECK(G0.col(2).cwiseAbs().maxCoeff() == 0.0);
  }
}
