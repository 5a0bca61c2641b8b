// Numerical helpers against closed forms and published values.
#include <chrono>
#include <cmath>
#include <mutex>
#include <set>
#include <thread>

#include "varbo/function.hpp"
#include "varbo/math.hpp"
#include "varbo/parallel.hpp"
#include "varbo_test.hpp"

using namespace varbo;

TEST_CASE("normal CDF and PDF against known values") {
  CHECK(normal_cdf(0.0) == doctest::Approx(0.5).epsilon(1e-15));
  CHECK(normal_cdf(1.959963984540054) == doctest::Approx(0.975).epsilon(1e-12));
  CHECK(normal_pdf(0.0) == doctest::Approx(1.0 / std::sqrt(2 * M_PI)).epsilon(1e-15));
  // log Φ in the far tail against log(erfc(30/sqrt 2)/2) computed in double (Python math.erfc)
  CHECK(normal_log_cdf(-30.0) == doctest::Approx(-454.3212439563431).epsilon(1e-10));
  CHECK(normal_log_cdf(-4.0) == doctest::Approx(std::log(3.167124183311992e-05)).epsilon(1e-10));
}

TEST_CASE("Gauss-Hermite integrates polynomials exactly and matches published nodes") {
  const GaussHermite& gh = gauss_hermite(45);
  CHECK(gh.nodes.size() == 45);
  // ∫ e^{-t²} t^{2k} dt = Γ(k + 1/2)
  for (int k = 0; k <= 10; ++k) {
    double s = 0;
    for (int i = 0; i < 45; ++i) s += gh.weights[i] * std::pow(gh.nodes[i], 2 * k);
    CHECK(s == doctest::Approx(std::tgamma(k + 0.5)).epsilon(1e-11));
  }
  // n = 3: nodes 0, ±sqrt(3/2); weights sqrt(pi)*2/3, sqrt(pi)/6 (Abramowitz & Stegun, table 25.10)
  const GaussHermite& g3 = gauss_hermite(3);
  CHECK(g3.nodes[2] == doctest::Approx(std::sqrt(1.5)).epsilon(1e-14));
  CHECK(g3.weights[1] == doctest::Approx(std::sqrt(M_PI) * 2.0 / 3.0).epsilon(1e-14));
  CHECK(g3.weights[0] == doctest::Approx(std::sqrt(M_PI) / 6.0).epsilon(1e-14));
}

TEST_CASE("robust Cholesky adds jitter only when needed") {
  Mat A(2, 2);
  A << 2, 1, 1, 2;
  RobustCholesky r = robust_cholesky(A);
  CHECK(r.ok);
  CHECK(r.jitter == 0);
  Mat S = Mat::Ones(3, 3);  // rank one: needs jitter
  RobustCholesky s = robust_cholesky(S);
  CHECK(s.ok);
  CHECK(s.jitter > 0);
  CHECK(s.jitter < 1e-3);
  Mat N = Mat::Identity(2, 2);
  N(0, 0) = NAN;
  CHECK_FALSE(robust_cholesky(N).ok);
}

TEST_CASE("log-normal prior density and gradient") {
  LogNormalPrior p{0.5, 2.0};
  double g;
  const double v = p.log_density(1.0, &g);
  CHECK(v == doctest::Approx(-0.5 * 0.0625 - std::log(2.0) - 0.5 * std::log(2 * M_PI)).epsilon(1e-14));
  FunctionRef f(1, [&](const Vec& x, Vec* grad) {
    double d;
    double val = p.log_density(x[0], &d);
    if (grad) *grad = Vec::Constant(1, d);
    return val;
  });
  CHECK(check_gradient(f, Vec::Constant(1, 1.3)).max_rel_error < 1e-7);
}

TEST_CASE("random streams are reproducible and independent of creation order") {
  Rng a(42), b(42);
  Rng s1 = a.stream(3, 7);
  a.uniform();
  Rng s2 = b.stream(3, 7);
  CHECK(s1.next() == s2.next());
  CHECK(Rng(42).stream(3, 7).next() != Rng(42).stream(3, 8).next());
  // Uniform mean and normal variance over many draws (4 standard errors).
  Rng r(1);
  double m = 0, v = 0;
  const int n = 200000;
  for (int i = 0; i < n; ++i) m += r.uniform();
  for (int i = 0; i < n; ++i) {
    const double z = r.normal();
    v += z * z;
  }
  CHECK(std::abs(m / n - 0.5) < 4 * std::sqrt(1.0 / 12 / n));
  CHECK(std::abs(v / n - 1.0) < 4 * std::sqrt(2.0 / n));
}

TEST_CASE("parallel_for fills every slot once with any thread count") {
  for (int threads : {1, 2}) {
    ThreadLimit limit(threads);
    std::vector<int> hits(100, 0);
    parallel_for(100, [&](Index i) { hits[static_cast<std::size_t>(i)] += 1; });
    for (int h : hits) CHECK(h == 1);
  }
}

TEST_CASE("ThreadLimit bounds the threads parallel_for uses while it lives") {
  // A study's `threads: 1` must hold for its fits on a shared machine (Study::ask, select, recommendation).
  const auto threads_used = [] {
    std::mutex m;
    std::set<std::thread::id> ids;
    parallel_for(64, [&](Index) {
      std::this_thread::sleep_for(std::chrono::microseconds(200));  // give other threads a chance to join
      std::lock_guard<std::mutex> lock(m);
      ids.insert(std::this_thread::get_id());
    });
    return ids.size();
  };
  {
    ThreadLimit one(1);
    CHECK(threads_used() == 1);
  }
  {
    ThreadLimit two(2);
    CHECK(threads_used() <= 2);
  }
}

TEST_CASE("check_gradient detects a wrong gradient") {
  FunctionRef wrong(2, [](const Vec& x, Vec* g) {
    if (g) *g = Vec::Constant(2, 1.0);
    return x.squaredNorm();
  });
  CHECK(check_gradient(wrong, Vec::Constant(2, 2.0)).max_rel_error > 0.5);
}

#include "varbo/numbers.hpp"

TEST_CASE("parse_decimal: decimal notation only") {
  CHECK(varbo::parse_decimal("12") == 12.0);
  CHECK(varbo::parse_decimal("-0.5") == -0.5);
  CHECK(varbo::parse_decimal("+.25") == 0.25);
  CHECK(varbo::parse_decimal("3.") == 3.0);
  CHECK(varbo::parse_decimal("1.5e-3") == 1.5e-3);
  CHECK(varbo::parse_decimal("2E+2") == 200.0);
  CHECK(varbo::parse_decimal("1e-320").has_value());  // subnormal: read, not refused
  CHECK(std::isinf(*varbo::parse_decimal("-Infinity")));
  CHECK(std::isnan(*varbo::parse_decimal("nan")));  // read, for the caller's own "must be finite" message
  for (const char* bad : {"", "0x10", "0X1p3", "1e999", "-1e400", " 1", "1 ", "1.2.3", "e5", ".", "-", "1e", "1e+",
                          "1,5", "infinit", "nan(1)", "١"})
    CHECK_MESSAGE(!varbo::parse_decimal(bad), "'" << bad << "'");
}
