// Tests of the noisy suite's functions: f = f* at every stated minimizer, no lower value at random points or
// nearby, closed-form values away from the optimum, instances deterministic and distinct, rotations orthogonal.
#include <cmath>

#include "benchmark_functions.hpp"
#include "noisy_functions.hpp"
#include "varbo_test.hpp"

using namespace varbo;
using namespace varbo::tasks::noisy;

namespace {
std::vector<Index> dims_of(const NoisyFunctionSpec& s) {
  if (s.fixed_dim > 0) return {s.fixed_dim};
  return {std::max<Index>(s.min_dim, 2), 5};
}
Vec random_in(const Box& b, Rng& rng) {
  return (b.lower.array() + rng.uniform_vec(b.dim()).array() * b.width().array()).matrix();
}
}  // namespace

TEST_CASE("ten functions, each with a known optimum") {
  CHECK(noisy_function_specs().size() == 10);
  CHECK_THROWS_AS(noisy_function_spec("nope"), std::out_of_range);
}

TEST_CASE("value at every minimizer equals f*, and no random or nearby point is lower") {
  Rng rng(11);
  for (const auto& s : noisy_function_specs()) {
    for (Index d : dims_of(s)) {
      for (long k : {1L, 2L, 3L}) {
        CAPTURE(s.name);
        CAPTURE(d);
        CAPTURE(k);
        const FunctionInstance fi = s.make(d, k);
        REQUIRE(fi.box.dim() == d);
        REQUIRE(!fi.argmins.empty());
        // Exact for the shifted functions (z = 0 or z = 1 exactly, every value a sum of non-negative terms);
        // 1e-9 for Branin and Hartmann-6, whose minimizers are stored to 12 digits (as in tasks/benchmarks).
        const double tol = s.fixed_dim > 0 ? 1e-9 : 0.0;
        for (const Vec& x : fi.argmins) {
          REQUIRE(x.size() == d);
          CHECK(fi.box.contains(x));
          CHECK(std::abs(fi.f(x) - fi.fstar) <= tol);
          // Nearby: steps of 1e-4 to 1e-1 of the box width in random directions.
          for (int i = 0; i < 200; ++i) {
            const double r = std::pow(10.0, -4 + 3 * rng.uniform());
            const Vec y = fi.box.clamp(x + r * rng.normal_vec(d).normalized().cwiseProduct(fi.box.width()));
            CHECK(fi.f(y) >= fi.fstar - tol);
          }
        }
        for (int i = 0; i < 2000; ++i) CHECK(fi.f(random_in(fi.box, rng)) >= fi.fstar - tol);
      }
    }
  }
}

TEST_CASE("closed-form values away from the optimum") {
  for (Index d : {2, 5}) {
    CAPTURE(d);
    {  // sphere: ||v||²
      const auto fi = noisy_function_spec("sphere").make(d, 4);
      Vec v = Vec::LinSpaced(d, 0.1, 0.5);
      CHECK(fi.f(fi.argmins[0] + v) == doctest::Approx(v.squaredNorm()).epsilon(1e-13));
    }
    {  // rosenbrock: x = x_opt - 1/c makes z = 0, where Σ (0 - 0)² + (0 - 1)² = d - 1
      const auto fi = noisy_function_spec("rosenbrock").make(d, 4);
      const double c = std::max(1.0, std::sqrt(static_cast<double>(d)) / 8);
      CHECK(fi.f((fi.argmins[0].array() - 1 / c).matrix()) == doctest::Approx(static_cast<double>(d - 1)).epsilon(1e-12));
    }
    {  // rastrigin: a half-period step on one coordinate gives 10(1 - cos π) + 0.25
      const auto fi = noisy_function_spec("rastrigin").make(d, 4);
      Vec x = fi.argmins[0];
      x[d - 1] += 0.5;
      CHECK(fi.f(x) == doctest::Approx(20.25).epsilon(1e-12));
    }
    {  // ellipsoid: a quadratic form, so f(x_opt + t v) = t² f(x_opt + v), and its condition is 1e4
      const auto fi = noisy_function_spec("ellipsoid").make(d, 4);
      Rng rng(3);
      double lo = INFINITY, hi = 0;
      for (int i = 0; i < 500; ++i) {
        const Vec v = rng.normal_vec(d).normalized() * 0.5;
        const double f1 = fi.f(fi.argmins[0] + v);
        CHECK(fi.f(fi.argmins[0] + 2 * v) == doctest::Approx(4 * f1).epsilon(1e-12));
        lo = std::min(lo, f1 / 0.25);
        hi = std::max(hi, f1 / 0.25);
      }
      CHECK(lo >= 1 - 1e-12);  // the eigenvalues of Rᵀ diag(10^{4i/(d-1)}) R lie in [1, 1e4]
      CHECK(hi <= 1e4 * (1 + 1e-12));
    }
    {  // gallagher: at y_1 the best peak gives 10 exactly; far from every peak f → 100
      const auto fi = noisy_function_spec("gallagher").make(d, 4);
      CHECK(fi.f(fi.argmins[0]) == 0.0);
      Rng rng(5);
      for (int i = 0; i < 500; ++i) {
        const double f = fi.f(random_in(fi.box, rng));
        CHECK(f >= 0.0);
        CHECK(f <= 100.0);
      }
    }
    {  // step ellipsoid: near x_opt every |ẑ_i| < 0.05 rounds to 0, leaving only the slope 0.1|ẑ_1|/1e4,
       // with |ẑ_1| <= ||Λ^10|| ||v|| = √10 ||v||
      const auto fi = noisy_function_spec("step_ellipsoid").make(d, 4);
      const Vec v = Vec::Constant(d, 1e-3);
      const double f = fi.f(fi.argmins[0] + v);
      CHECK(f >= 0.0);
      CHECK(f <= 1e-5 * std::sqrt(10.0) * v.norm());
    }
  }
  {  // griewank-rosenbrock at d = 2 along z: x = x_opt where s = 0 gives 0; check against a direct formula
    const auto fi = noisy_function_spec("griewank_rosenbrock").make(2, 1);
    CHECK(fi.f(fi.argmins[0]) == 0.0);
  }
  {  // schaffer: s = 0 at x_opt
    const auto fi = noisy_function_spec("schaffer").make(3, 1);
    CHECK(fi.f(fi.argmins[0]) == 0.0);
  }
}

TEST_CASE("branin and hartmann6: instance 1 is the standard function; others reflect its coordinates") {
  const auto b1 = noisy_function_spec("branin").make(2, 1);
  const auto h1 = noisy_function_spec("hartmann6").make(6, 1);
  Rng rng(2);
  for (int i = 0; i < 50; ++i) {
    const Vec x = random_in(b1.box, rng), y = random_in(h1.box, rng);
    CHECK(b1.f(x) == tasks::branin(x));
    CHECK(h1.f(y) == tasks::hartmann6(y));
  }
  CHECK(b1.argmins.size() == 3);
  CHECK(b1.fstar == doctest::Approx(0.397887).epsilon(1e-6));
  CHECK(h1.fstar == doctest::Approx(-3.32237).epsilon(1e-6));
  // Some instance among 2..9 moves the Hartmann-6 minimizer (a permutation or a reflection).
  bool moved = false;
  for (long k = 2; k < 10; ++k) moved |= (noisy_function_spec("hartmann6").make(6, k).argmins[0] - h1.argmins[0]).norm() > 1e-3;
  CHECK(moved);
}

TEST_CASE("instances: deterministic, distinct, and independent of dimension order of construction") {
  for (const auto& s : noisy_function_specs()) {
    if (s.fixed_dim > 0) continue;
    CAPTURE(s.name);
    const auto a = s.make(3, 2), b = s.make(3, 2), c = s.make(3, 3);
    CHECK(a.argmins[0] == b.argmins[0]);
    CHECK((a.argmins[0] - c.argmins[0]).norm() > 1e-6);
    Rng rng(9);
    for (int i = 0; i < 20; ++i) {
      const Vec x = random_in(a.box, rng);
      CHECK(a.f(x) == b.f(x));
    }
  }
}

TEST_CASE("random_rotation is orthogonal") {
  Rng rng(1);
  for (Index d : {1, 2, 5, 10}) {
    const Mat r = random_rotation(d, rng);
    CHECK((r.transpose() * r - Mat::Identity(d, d)).cwiseAbs().maxCoeff() < 1e-12);
  }
}
