// The near-pair noise bound (noise_bound.hpp): the χ² quantile against closed-form distribution functions, the
// bound against a hand computation, its error rate under real noise by simulation, and the gp's use of it.
#include <algorithm>
#include <cmath>
#include <vector>

#include "ceres_lbfgs.hpp"
#include "gp_surrogate.hpp"
#include "kernel_library.hpp"
#include "noise_bound.hpp"
#include "varbo_test.hpp"

using namespace varbo;
using namespace varbo::gp;

namespace {

/// The p-quantile of χ²_1 by bisection on its distribution function erf(sqrt(x/2)) (independent of Boost).
double chi2_1_quantile_by_bisection(double p) {
  double lo = 0, hi = 100;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (std::erf(std::sqrt(mid / 2)) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

TEST_CASE("chi2_quantile inverts the closed-form χ² distribution functions (dof 1, 2, 4)") {
  for (const double p : {1e-8, 1e-5, 1e-3, 0.05, 0.5, 0.9}) {
    CAPTURE(p);
    // dof 2: F(x) = 1 − exp(−x/2); dof 4: F(x) = 1 − exp(−x/2)(1 + x/2); dof 1: F(x) = erf(sqrt(x/2)).
    const double q2 = chi2_quantile(2, p), q4 = chi2_quantile(4, p), q1 = chi2_quantile(1, p);
    CHECK(q2 == doctest::Approx(-2.0 * std::log1p(-p)).epsilon(1e-12));
    CHECK(-std::expm1(-q4 / 2) - std::exp(-q4 / 2) * q4 / 2 == doctest::Approx(p).epsilon(1e-9));
    CHECK(q1 == doctest::Approx(chi2_1_quantile_by_bisection(p)).epsilon(1e-9));
  }
  CHECK_THROWS_AS(chi2_quantile(2, 0.0), std::invalid_argument);
  CHECK_THROWS_AS(chi2_quantile(0, 0.5), std::invalid_argument);
}

TEST_CASE("near_pair_noise_bound: the nearest disjoint pairs, by hand") {
  // Points 0,1 at distance 0.01, points 2,3 at 0.02, all other pairs farther: the pairs are (0,1) and (2,3),
  // cost differences 0.3 and 0.4; M = 2 tests at level alpha/2.
  Mat X(4, 1);
  X << 0.0, 0.01, 0.5, 0.52;
  const Vec y = (Vec(4) << 1.0, 1.3, 2.0, 1.6).finished();
  const double alpha = 0.01;
  const double u1 = 0.3 / std::sqrt(2 * chi2_1_quantile_by_bisection(alpha / 2));
  const double u2 = std::sqrt((0.09 + 0.16) / (2 * -2.0 * std::log1p(-alpha / 2)));
  const NearPairNoiseBound b = near_pair_noise_bound(X, y, alpha);
  CHECK(b.bound == doctest::Approx(std::min(u1, u2)).epsilon(1e-9));
  CHECK(b.pairs == (u1 < u2 ? 1 : 2));
  // Exact replicates of a deterministic cost rule out any noise; a single point bounds nothing.
  Mat R(3, 1);
  R << 0.2, 0.2, 0.9;
  CHECK(near_pair_noise_bound(R, (Vec(3) << 5.0, 5.0, 1.0).finished(), alpha).bound == 0.0);
  CHECK(std::isinf(near_pair_noise_bound(Mat::Zero(1, 2), Vec::Ones(1), alpha).bound));
  CHECK_THROWS_AS(near_pair_noise_bound(X, y, 0.0), std::invalid_argument);
}

TEST_CASE("near_pair_noise_bound: replicates pooled by hand, and the same bound whatever the rows' order") {
  // Red team, session 25: 20 policies evaluated 3 times each, noise sd 0.01 where x < 0.5 and 0.3 elsewhere; with the
  // quiet replicates listed first the pairs at distance 0 were taken in row order and the bound (a cap on the gp's
  // noise) was 0.036, with the rows reversed 0.17.
  Rng rng(4);
  const Index groups = 20, reps = 3, n = groups * reps;
  Mat X(n, 1);
  Vec y(n);
  for (Index g = 0; g < groups; ++g)
    for (Index r = 0; r < reps; ++r) {
      const double x = (g + 0.5) / groups;
      X(g * reps + r, 0) = x;
      y(g * reps + r) = std::sin(6 * x) + (x < 0.5 ? 0.01 : 0.3) * rng.normal();
    }
  // By hand: the replicates are one stage, S = Σ_g Σ_r (y − ȳ_g)² with 40 degrees of freedom, tested alone (M = 1).
  double ss = 0;
  for (Index g = 0; g < groups; ++g) {
    const double mean = y.segment(g * reps, reps).mean();
    ss += (y.segment(g * reps, reps).array() - mean).square().sum();
  }
  const double alpha = 0.05;
  const NearPairNoiseBound b = near_pair_noise_bound(X, y, alpha);
  CHECK(b.bound == doctest::Approx(std::sqrt(ss / chi2_quantile(40, alpha))).epsilon(1e-12));
  CHECK(b.pairs == 1);
  CHECK(b.bound > 0.1);  // the noisy half's replicates count: the pooled sd is ~0.21
  // Any order of the rows: the same bound, to the last bit.
  for (int shuffle = 0; shuffle < 5; ++shuffle) {
    std::vector<Index> perm(static_cast<std::size_t>(n));
    for (Index i = 0; i < n; ++i) perm[static_cast<std::size_t>(i)] = shuffle == 0 ? n - 1 - i : i;
    if (shuffle > 0) std::shuffle(perm.begin(), perm.end(), rng.engine());
    Mat Xp(n, 1);
    Vec yp(n);
    for (Index i = 0; i < n; ++i) {
      Xp(i, 0) = X(perm[static_cast<std::size_t>(i)], 0);
      yp(i) = y(perm[static_cast<std::size_t>(i)]);
    }
    CHECK(near_pair_noise_bound(Xp, yp, alpha).bound == b.bound);
  }
  // Random points with a few replicates and ties in distance (a grid): any order, the same bound.
  Mat G(30, 2);
  Vec gy(30);
  for (Index i = 0; i < 30; ++i) {
    G(i, 0) = 0.1 * static_cast<double>(i % 6);
    G(i, 1) = 0.1 * static_cast<double>((i / 6) % 4);  // rows 24-29 repeat rows 0-5
    gy(i) = G(i, 0) + 0.05 * rng.normal();
  }
  const double reference = near_pair_noise_bound(G, gy, alpha).bound;
  CHECK(std::isfinite(reference));
  for (int shuffle = 0; shuffle < 5; ++shuffle) {
    std::vector<Index> perm(30);
    for (Index i = 0; i < 30; ++i) perm[static_cast<std::size_t>(i)] = i;
    std::shuffle(perm.begin(), perm.end(), rng.engine());
    Mat Gp(30, 2);
    Vec gyp(30);
    for (Index i = 0; i < 30; ++i) {
      Gp.row(i) = G.row(perm[static_cast<std::size_t>(i)]);
      gyp(i) = gy(perm[static_cast<std::size_t>(i)]);
    }
    CHECK(near_pair_noise_bound(Gp, gyp, alpha).bound == reference);
  }
}

TEST_CASE("near_pair_noise_bound: below the true noise at most alpha of the time; near a smooth cost's slope·distance") {
  // 4000 data sets of 40 uniform points in the unit square, y = 3 sin(4 x_1) + x_2 + N(0, σ²) with σ = 0.1: the
  // bound falls below σ in at most alpha = 0.05 of them (the binomial sd of the rate is 0.0034; allowed 0.05 + 4 sd).
  Rng rng(11);
  const double sigma = 0.1, alpha = 0.05;
  const int reps = 4000;
  int below = 0;
  for (int r = 0; r < reps; ++r) {
    Mat X(40, 2);
    for (Index i = 0; i < 40; ++i) X.row(i) = rng.uniform_vec(2).transpose();
    Vec y(40);
    for (Index i = 0; i < 40; ++i) y(i) = 3 * std::sin(4 * X(i, 0)) + X(i, 1) + sigma * rng.normal();
    below += near_pair_noise_bound(X, y, alpha).bound < sigma;
  }
  MESSAGE("bound below the true noise in " << below << " of " << reps);
  CHECK(below <= static_cast<int>((alpha + 4 * 0.0034) * reps));
  // Noise-free, with 20 pairs 1e-4 apart: the differences are at most |∇f|·1e-4 ≤ 12.1e-4, and so is the RMS of any
  // m of them; the bound is that RMS over sqrt(2 q_m / m), ≥ 0.3 for m ≥ 10 at level 1e-3/20, so < 4.1e-3.
  Mat X(40, 2);
  for (Index i = 0; i < 20; ++i) {
    X.row(2 * i) = rng.uniform_vec(2).transpose() * 0.99;
    X.row(2 * i + 1) = X.row(2 * i) + Eigen::RowVector2d(1e-4, 0.0);
  }
  Vec y(40);
  for (Index i = 0; i < 40; ++i) y(i) = 3 * std::sin(4 * X(i, 0)) + X(i, 1);
  CHECK(2 * chi2_quantile(10, 1e-3 / 20) / 10 > 0.3 * 0.3);
  CHECK(near_pair_noise_bound(X, y, 1e-3).bound < 4.1e-3);
}

TEST_CASE("gp with noise_test_level: the fitted noise stays within the data's bound") {
  // A deterministic rippled cost (period 0.1, the ripples a tenth of the trend) at 30 points plus a near twin of
  // each (1e-4 apart): without the test the fit may take the ripples for noise; with it σ_n ≤ the bound.
  Rng rng(5);
  Mat X(60, 1);
  for (Index i = 0; i < 30; ++i) {
    X(2 * i, 0) = rng.uniform() * 0.999;
    X(2 * i + 1, 0) = X(2 * i, 0) + 1e-4;
  }
  Vec y(60);
  for (Index i = 0; i < 60; ++i) y(i) = 10 * X(i, 0) * X(i, 0) + std::cos(20 * M_PI * X(i, 0));
  GpSettings s;
  s.kernel = [](Index d) { return kernels::make_stationary_ard(kernels::KernelType::SquaredExponential, d); };
  s.noise_test_level = 1e-3;
  GpSurrogate gp(1, s, std::make_shared<ceres_lbfgs::CeresLbfgs>());
  Rng fit_rng(6);
  REQUIRE(gp.fit(Dataset{X, y}, fit_rng).ok);
  double noise = 0;
  for (const auto& h : gp.hyperparameters())
    if (h.name == "noise_std") noise = h.value;
  const double bound = near_pair_noise_bound(X, y, 1e-3).bound;
  MESSAGE("σ_n = " << noise << ", bound " << bound);
  // The box is in standardized log units: allow the round trip's rounding, or the floor if the bound is below it.
  CHECK(noise <= std::max(bound, 1e-6 * 1.1 * std::sqrt((y.array() - y.mean()).square().sum() / 59)) * (1 + 1e-9));
}

TEST_CASE("noise_test_tight: a replicate with real noise keeps the noise mode; an exact replicate selects the tight prior") {
  // Noisy data (σ = 0.1) whose last point replicates the first with its own noise draw: the bound stays far above
  // kNoNoiseBound, so the fit is the capped one and finds the noise (within 50 %, as test_gp's "finds real noise").
  Rng rng(7);
  const Index n = 80;
  Mat X(n, 2);
  for (Index i = 0; i < n; ++i) X.row(i) = rng.uniform_vec(2).transpose();
  X.row(n - 1) = X.row(0);
  Vec f(n);
  for (Index i = 0; i < n; ++i) f(i) = 2 * std::sin(6 * X(i, 0)) + std::cos(3 * X(i, 1));
  const Vec noisy = f + 0.1 * rng.normal_vec(n);
  GpSettings s;
  s.kernel = [](Index d) { return kernels::make_stationary_ard(kernels::KernelType::SquaredExponential, d); };
  s.noise_test_level = 1e-3;
  s.noise_test_tight = true;
  const auto noise_of = [](const GpSurrogate& gp) {
    for (const auto& h : gp.hyperparameters())
      if (h.name == "noise_std") return h.value;
    return -1.0;
  };
  {
    GpSurrogate gp(2, s, std::make_shared<ceres_lbfgs::CeresLbfgs>());
    Rng fit_rng(8);
    REQUIRE(gp.fit(Dataset{X, noisy}, fit_rng).ok);
    MESSAGE("noisy, one replicate: σ_n = " << noise_of(gp));
    CHECK(std::abs(noise_of(gp) / 0.1 - 1.0) < 0.5);
  }
  // The noise-free cost with the exact replicate: the bound is 0. Capped (noise_test_tight off) the noise sits on
  // the floor (here 1e-9·std(y)); with noise_test_tight the tight prior (median 1e-6) holds it well above the floor.
  CHECK(near_pair_noise_bound(X, f, 1e-3).bound == 0.0);
  s.min_noise_std = 1e-9;
  const double sd = std::sqrt((f.array() - f.mean()).square().sum() / static_cast<double>(n - 1));
  for (const bool tight : {false, true}) {
    CAPTURE(tight);
    s.noise_test_tight = tight;
    GpSurrogate gp(2, s, std::make_shared<ceres_lbfgs::CeresLbfgs>());
    Rng fit_rng(8);
    REQUIRE(gp.fit(Dataset{X, f}, fit_rng).ok);
    MESSAGE("noise-free, exact replicate: σ_n / std(y) = " << noise_of(gp) / sd);
    if (tight) {
      CHECK(noise_of(gp) / sd > 1e-8);
      CHECK(noise_of(gp) / sd < 1e-3);
    } else {
      CHECK(noise_of(gp) / sd == doctest::Approx(s.min_noise_std).epsilon(1e-6));
    }
  }
}
