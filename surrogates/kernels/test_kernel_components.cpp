// Every kernel component through the varbo::Kernel interface: gradients against central finite differences,
// positive semi-definiteness, closed forms, names, the hyperprior, and YAML errors.
#include <Eigen/Eigenvalues>
#include <cmath>
#include <functional>

#include "kernel_library.hpp"
#include "varbo/function.hpp"
#include "varbo_test.hpp"

using namespace varbo;
using namespace varbo::kernels;

namespace {

constexpr Index kDim = 3;

Mat random_points(Index n, Index d, std::uint64_t seed) {
  Rng rng(seed);
  Mat X(n, d);
  for (Index i = 0; i < n; ++i) X.row(i) = rng.uniform_vec(d).transpose();
  return X;
}

std::vector<std::unique_ptr<Kernel>> terms(std::unique_ptr<Kernel> a, std::unique_ptr<Kernel> b) {
  std::vector<std::unique_ptr<Kernel>> t;
  t.push_back(std::move(a));
  t.push_back(std::move(b));
  return t;
}

struct Case {
  std::string name;
  std::function<std::unique_ptr<Kernel>()> make;
  bool index_noise = false;  ///< has a white term: cross(X, X) ≠ matrix(X)
};

std::vector<Case> cases() {
  using K = KernelType;
  return {
      {"se_ard", [] { return make_stationary_ard(K::SquaredExponential, kDim); }},
      {"matern12_ard", [] { return make_stationary_ard(K::Matern12, kDim); }},
      {"matern32_ard", [] { return make_stationary_ard(K::Matern32, kDim); }},
      {"matern52_ard", [] { return make_stationary_ard(K::Matern52, kDim); }},
      {"rational_quadratic", [] { return make_rational_quadratic(kDim); }},
      {"linear", [] { return make_linear(kDim); }},
      {"constant", [] { return make_constant(kDim); }},
      {"white", [] { return make_white(kDim); }, true},
      {"sum(se, constant)",
       [] { return make_sum(terms(make_stationary_ard(K::SquaredExponential, kDim), make_constant(kDim))); }},
      {"sum(se, white)",
       [] { return make_sum(terms(make_stationary_ard(K::SquaredExponential, kDim), make_white(kDim))); }, true},
      {"product(matern32, linear)",
       [] { return make_product(terms(make_stationary_ard(K::Matern32, kDim), make_linear(kDim))); }},
      {"product(sum(rq, constant), matern52)", [] {
         return make_product(terms(make_sum(terms(make_rational_quadratic(kDim), make_constant(kDim))),
                                   make_stationary_ard(K::Matern52, kDim)));
       }},
  };
}

/// A kernel with random values around the priors' medians (seeded).
std::unique_ptr<Kernel> randomized(const Case& c, std::uint64_t seed) {
  auto k = c.make();
  Rng rng(seed);
  Vec p = k->log_params();
  for (Index j = 0; j < p.size(); ++j) p(j) += rng.uniform(-0.5, 0.5);
  k->set_log_params(p);
  return k;
}

}  // namespace

TEST_CASE("every kernel: matrix_gradients match central differences of matrix()") {
  // h = 1e-6 in log space; entries are O(1) (≤ ~10 for products), tolerance 1e-6 absolute.
  for (const Case& c : cases()) {
    CAPTURE(c.name);
    auto k = randomized(c, 3);
    const Mat X = random_points(7, kDim, 4);
    const auto G = k->matrix_gradients(X);
    REQUIRE(static_cast<Index>(G.size()) == k->num_params());
    const Vec p0 = k->log_params();
    const double h = 1e-6;
    for (Index j = 0; j < k->num_params(); ++j) {
      Vec p = p0;
      p(j) += h;
      k->set_log_params(p);
      const Mat Kp = k->matrix(X);
      p(j) -= 2 * h;
      k->set_log_params(p);
      const Mat Km = k->matrix(X);
      k->set_log_params(p0);
      CAPTURE(k->names()[static_cast<std::size_t>(j)]);
      CHECK(((Kp - Km) / (2 * h) - G[static_cast<std::size_t>(j)]).cwiseAbs().maxCoeff() < 1e-6);
    }
  }
}

TEST_CASE("every kernel: contract_gradient equals ½ Σ W∘∂K and the finite differences of ½ Σ W∘K") {
  // Two analytic routes agree to 1e-10 relative; against FD (check_gradient, h ~ 1e-6) to 1e-6 relative.
  for (const Case& c : cases()) {
    CAPTURE(c.name);
    const auto k = randomized(c, 21);
    Mat X = random_points(11, kDim, 22);
    X.row(5) = X.row(2);  // a duplicated point (r = 0): no special case may break
    Mat W = random_points(11, 11, 23).array() - 0.5;
    W = (W + W.transpose()).eval();
    const Vec g = k->contract_gradient(X, W);
    const auto G = k->matrix_gradients(X);
    for (Index j = 0; j < k->num_params(); ++j) {
      CAPTURE(k->names()[static_cast<std::size_t>(j)]);
      CHECK(g(j) == doctest::Approx(0.5 * (W.array() * G[static_cast<std::size_t>(j)].array()).sum()).epsilon(1e-10));
    }
    FunctionRef f(k->num_params(), [&](const Vec& p, Vec* grad) {
      auto kk = k->clone();
      kk->set_log_params(p);
      if (grad) *grad = kk->contract_gradient(X, W);
      return 0.5 * (W.array() * kk->matrix(X).array()).sum();
    });
    const GradientCheck chk = check_gradient(f, k->log_params());
    CAPTURE(chk.analytic.transpose());
    CAPTURE(chk.numeric.transpose());
    CHECK(chk.max_rel_error < 1e-6);
  }
}

TEST_CASE("every kernel: cross_gradient_x matches finite differences of cross_vec") {
  // check_gradient on each k(x, X_i) away from the data (Matérn-1/2 has a kink at x = X_i); 1e-6 relative.
  for (const Case& c : cases()) {
    CAPTURE(c.name);
    const auto k = randomized(c, 31);
    const Mat X = random_points(5, kDim, 32);
    const Vec x = random_points(1, kDim, 33).row(0).transpose();
    const Mat G = k->cross_gradient_x(x, X);
    REQUIRE(G.rows() == kDim);
    REQUIRE(G.cols() == X.rows());
    for (Index i = 0; i < X.rows(); ++i) {
      FunctionRef f(kDim, [&](const Vec& z, Vec* grad) {
        if (grad) *grad = k->cross_gradient_x(z, X).col(i);
        return k->cross_vec(z, X)(i);
      });
      CAPTURE(i);
      CHECK(check_gradient(f, x).max_rel_error < 1e-6);
    }
  }
}

TEST_CASE("every kernel: K is symmetric PSD; matrix, cross, cross_vec and diagonal agree") {
  for (const Case& c : cases()) {
    CAPTURE(c.name);
    const auto k = randomized(c, 7);
    const Mat X = random_points(30, kDim, 11);
    const Mat Z = random_points(4, kDim, 12);
    const Mat K = k->matrix(X);
    CHECK((K - K.transpose()).cwiseAbs().maxCoeff() <= 1e-14 * K.cwiseAbs().maxCoeff());
    const Eigen::SelfAdjointEigenSolver<Mat> es(K);
    // Smallest eigenvalue non-negative up to round-off relative to the largest.
    CHECK(es.eigenvalues().minCoeff() > -1e-12 * es.eigenvalues().maxCoeff());
    const Mat KXZ = k->cross(X, Z);
    for (Index j = 0; j < Z.rows(); ++j) {
      CHECK((k->cross_vec(Z.row(j).transpose(), X) - KXZ.col(j)).cwiseAbs().maxCoeff() < 1e-14);
      // k(z, z) = K(z, z) on a one-point set, white noise included.
      CHECK(k->diagonal(Z.row(j).transpose()) == doctest::Approx(k->matrix(Z.row(j))(0, 0)).epsilon(1e-14));
    }
    if (!c.index_noise) CHECK((K - k->cross(X, X)).cwiseAbs().maxCoeff() < 1e-13);
  }
}

TEST_CASE("every kernel: the hyperprior's gradient matches finite differences; clone is independent") {
  for (const Case& c : cases()) {
    CAPTURE(c.name);
    const auto k = randomized(c, 41);
    FunctionRef f(k->num_params(), [&](const Vec& p, Vec* grad) { return k->log_prior(p, grad); });
    CHECK(check_gradient(f, k->log_params()).max_rel_error < 1e-6);
    const Box box = k->log_box();
    CHECK((box.lower.array() < box.upper.array()).all());
    auto copy = k->clone();
    const Vec before = k->log_params();
    copy->set_log_params(before.array() + 0.1);
    CHECK((k->log_params() - before).cwiseAbs().maxCoeff() == 0.0);
  }
}

TEST_CASE("closed forms") {
  const Mat X = random_points(6, kDim, 51);
  SUBCASE("Matérn-1/2 is the exponential kernel σ² exp(−r)") {
    auto k = make_stationary_ard(KernelType::Matern12, kDim);
    Vec p(kDim + 1);
    p << std::log(0.3), std::log(0.7), std::log(1.9), std::log(1.3);
    k->set_log_params(p);
    const Mat K = k->matrix(X);
    for (Index i = 0; i < X.rows(); ++i)
      for (Index j = 0; j < X.rows(); ++j) {
        const Vec d = (X.row(i) - X.row(j)).transpose();
        const double r = std::sqrt(std::pow(d(0) / 0.3, 2) + std::pow(d(1) / 0.7, 2) + std::pow(d(2) / 1.9, 2));
        CHECK(K(i, j) == doctest::Approx(1.69 * std::exp(-r)).epsilon(1e-13));
      }
  }
  SUBCASE("Matérn-3/2: σ² (1 + √3 r) exp(−√3 r)") {
    auto k = make_stationary_ard(KernelType::Matern32, kDim);
    k->set_log_params(Vec::Constant(kDim + 1, std::log(0.5)));
    const Mat K = k->matrix(X);
    const double r = (X.row(0) - X.row(1)).norm() / 0.5;
    CHECK(K(0, 1) == doctest::Approx(0.25 * (1 + std::sqrt(3.0) * r) * std::exp(-std::sqrt(3.0) * r)).epsilon(1e-13));
  }
  SUBCASE("rational quadratic tends to SE as α → ∞; α = 1 is the Cauchy form 1/(1 + r²/2)") {
    auto rq = make_rational_quadratic(kDim);
    auto se = make_stationary_ard(KernelType::SquaredExponential, kDim);
    Vec p(kDim + 2);
    p << std::log(0.4), std::log(0.6), std::log(0.8), std::log(1.2), std::log(1e7);
    rq->set_log_params(p);
    se->set_log_params(p.head(kDim + 1));
    // (1 + u/α)^{−α} = e^{−u}(1 + O(u²/α)): with α = 1e7 and u ≤ ~10 the relative gap is ≤ ~1e-5.
    CHECK((rq->matrix(X) - se->matrix(X)).cwiseAbs().maxCoeff() < 1e-5);
    p(kDim + 1) = 0.0;
    rq->set_log_params(p);
    const Vec d = (X.row(2) - X.row(4)).transpose();
    const double r2 = std::pow(d(0) / 0.4, 2) + std::pow(d(1) / 0.6, 2) + std::pow(d(2) / 0.8, 2);
    CHECK(rq->matrix(X)(2, 4) == doctest::Approx(1.44 / (1 + 0.5 * r2)).epsilon(1e-13));
  }
  SUBCASE("linear, constant, white, sum and product") {
    auto lin = make_linear(kDim), con = make_constant(kDim), wn = make_white(kDim);
    lin->set_log_params(Vec::Constant(1, std::log(2.0)));
    con->set_log_params(Vec::Constant(1, std::log(3.0)));
    wn->set_log_params(Vec::Constant(1, std::log(0.1)));
    CHECK(lin->matrix(X)(1, 3) == doctest::Approx(4.0 * X.row(1).dot(X.row(3))).epsilon(1e-14));
    CHECK(con->matrix(X)(1, 3) == doctest::Approx(9.0).epsilon(1e-15));
    CHECK(wn->matrix(X)(1, 3) == 0.0);
    CHECK(wn->matrix(X)(2, 2) == doctest::Approx(0.01).epsilon(1e-14));
    const Mat L = lin->matrix(X), C = con->matrix(X);
    auto s = make_sum(terms(lin->clone(), con->clone()));
    s->set_log_params((Vec(2) << std::log(2.0), std::log(3.0)).finished());
    CHECK((s->matrix(X) - (L + C)).cwiseAbs().maxCoeff() < 1e-13);
    auto prod = make_product(terms(lin->clone(), con->clone()));
    prod->set_log_params((Vec(2) << std::log(2.0), std::log(3.0)).finished());
    CHECK((prod->matrix(X) - L.cwiseProduct(C)).cwiseAbs().maxCoeff() < 1e-12);
  }
}

TEST_CASE("names are stable; composites prefix them; only a product's first amplitude scales with the costs") {
  const auto se = make_stationary_ard(KernelType::SquaredExponential, 2);
  CHECK(se->names() == std::vector<std::string>{"lengthscale[0]", "lengthscale[1]", "signal_std"});
  CHECK(make_rational_quadratic(1)->names() == std::vector<std::string>{"lengthscale[0]", "signal_std", "alpha"});
  CHECK(make_white(1)->names() == std::vector<std::string>{"noise_std"});
  const auto sum = make_sum(terms(make_stationary_ard(KernelType::Matern52, 1), make_constant(1)));
  CHECK(sum->names() == std::vector<std::string>{"terms[0].lengthscale[0]", "terms[0].signal_std", "terms[1].signal_std"});
  CHECK(sum->parameters()[1].scales_with_output);
  CHECK(sum->parameters()[2].scales_with_output);
  const auto prod = make_product(terms(make_stationary_ard(KernelType::Matern52, 1), make_constant(1)));
  CHECK(prod->parameters()[1].scales_with_output);
  CHECK_FALSE(prod->parameters()[2].scales_with_output);
  // Role defaults reach every term.
  auto s2 = sum->clone();
  s2->set_role_defaults(KernelParameterRole::Amplitude, {0.5, 2.0}, 0.1, 10.0);
  CHECK(s2->log_box().upper(2) == doctest::Approx(std::log(10.0)));
  Vec g;
  const Vec p = Vec::Zero(3);
  // lengthscale prior (default) + two amplitude priors N(0 | 0.5, 2²)
  const double amp = -0.5 * std::pow(0.5 / 2.0, 2) - std::log(2.0) - 0.5 * std::log(2 * M_PI);
  const double ell = -0.5 * std::pow(std::log(0.5), 2) - 0.5 * std::log(2 * M_PI);
  CHECK(s2->log_prior(p, &g) == doctest::Approx(ell + 2 * amp).epsilon(1e-14));
}

TEST_CASE("kernel components from YAML, and their errors with file:line:col") {
  Registry& r = test::registry();
  BuildContext ctx;
  ctx.dim = 2;
  const auto k = r.create<Kernel>("{type: sum, terms: [se_ard, {type: product, terms: [matern32_ard, linear]}]}", ctx);
  CHECK(k->dim() == 2);
  CHECK(k->names().back() == "terms[1].terms[1].signal_std");
  CHECK(r.create<Kernel>("se_ard", ctx)->names().size() == 3);  // the shorthand: a name alone
  auto message = [&](const std::string& yaml) {
    try {
      r.create<Kernel>(yaml, ctx);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string unknown = message("{type: sum, terms: [se_ard, rbf]}");
  CHECK(unknown.find("<inline>:1:") != std::string::npos);
  CHECK(unknown.find("rbf") != std::string::npos);
  const std::string empty = message("{type: sum, terms: []}");
  CHECK(empty.find("<inline>:1:") != std::string::npos);
  CHECK(empty.find("non-empty list of kernels") != std::string::npos);
  const std::string not_kernel = message("{type: product, terms: [se_ard, ei]}");  // an acquisition
  CHECK(not_kernel.find("<inline>:1:") != std::string::npos);
  CHECK(not_kernel.find("'ei'") != std::string::npos);
  CHECK(message("{type: sum}").find("terms") != std::string::npos);
  CHECK(message("{type: sum, terms: se_ard}").find("non-empty list of kernels") != std::string::npos);
}
