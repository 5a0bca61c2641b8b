// The GP classifier of failure-aware BO (feasibility_model.hpp): probit derivatives, the Laplace mode and
// predictive against independent closed forms, symmetry and limits on a separable 1-D case, and the gradient
// of P(success | x) by central differences.
#include <cmath>
#include <vector>

#include "feasibility_model.hpp"
#include "kernel.hpp"
#include "varbo/function.hpp"
#include "varbo/math.hpp"
#include "varbo_test.hpp"

using namespace varbo;
using varbo::bo::FeasibilityModel;

namespace {
Mat column(const std::vector<double>& xs) {
  Mat X(static_cast<Index>(xs.size()), 1);
  for (std::size_t i = 0; i < xs.size(); ++i) X(static_cast<Index>(i), 0) = xs[i];
  return X;
}
Vec vec1(double x) { return Vec::Constant(1, x); }
}  // namespace

TEST_CASE("probit log-likelihood derivatives match central differences of log Φ(y f)") {
  for (double y : {-1.0, 1.0})
    for (double f : {-40.0, -25.0, -6.0, -1.0, 0.0, 0.7, 3.0, 12.0}) {  // not at −30, normal_log_cdf's switch
      const double h = 1e-4;
      auto L = [&](double v) { return normal_log_cdf(y * v); };
      const double d1 = (L(f + h) - L(f - h)) / (2 * h);
      const double d2 = (L(f + h) - 2 * L(f) + L(f - h)) / (h * h);
      const bo::ProbitTerms t = bo::probit_terms(y, f);
      CAPTURE(y);
      CAPTURE(f);
      CHECK(t.log_likelihood == doctest::Approx(L(f)).epsilon(1e-14));
      CHECK(t.d1 == doctest::Approx(d1).epsilon(1e-6));
      CHECK(std::abs(t.w + d2) < 1e-5 + 1e-4 * std::abs(d2));  // second differences: ~1e-16 |L| / h² of noise
      CHECK(t.w >= 0);  // log-concave
    }
}

TEST_CASE("one failed trial: the Laplace mode and predictive equal the scalar closed form") {
  // With one point the mode solves the scalar equation f = m + k·∂log Φ(y f)/∂f (R&W eq. 3.17), solved here by
  // bisection; the predictive at the point is N(f̂, k − k²/(k + 1/W)) (R&W eqs. 3.21, 3.24).
  FeasibilityModel model(1);
  const FeasibilityModel::Hyper h{1.0, 2.0};
  REQUIRE(model.fit(column({0.4}), {false}, vec1(0.2), false, h));
  const double k = h.signal_std * h.signal_std;
  // Far from the data P(success) is the smoothed success rate (0 + 1)/(1 + 2) = 1/3 (the prior mean's definition).
  CHECK(model.probability(vec1(40.0)) == doctest::Approx(1.0 / 3.0).epsilon(1e-9));
  const double m = model.prior_mean();
  CHECK(normal_cdf(m / std::sqrt(1 + k)) == doctest::Approx(1.0 / 3.0).epsilon(1e-9));
  double lo = m - 20, hi = m;  // the failure pulls the latent below the prior mean
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    const double r = mid - m - k * bo::probit_terms(-1.0, mid).d1;
    (r < 0 ? lo : hi) = mid;
  }
  const double fhat = 0.5 * (lo + hi);
  CHECK(model.mode()(0) == doctest::Approx(fhat).epsilon(1e-8));
  const double W = bo::probit_terms(-1.0, fhat).w;
  double mean = 0, var = 0;
  model.latent(vec1(0.4), mean, var);
  CHECK(mean == doctest::Approx(fhat).epsilon(1e-8));
  CHECK(var == doctest::Approx(k - k * k / (k + 1.0 / W)).epsilon(1e-8));
  CHECK(model.probability(vec1(0.4)) == doctest::Approx(normal_cdf(fhat / std::sqrt(1 + var))).epsilon(1e-12));
  CHECK(model.probability(vec1(0.4)) < 1.0 / 3.0);  // less likely to succeed at the failure than anywhere else
}

TEST_CASE("a given prior success rate is the probability far from every trial, for every grid hyperparameter") {
  for (const FeasibilityModel::Hyper& h : FeasibilityModel::grid()) {
    FeasibilityModel model(1);
    model.set_prior_success_rate(0.625);
    REQUIRE(model.fit(column({0.2, 0.5, 0.6}), {false, true, true}, vec1(0.2), false, h));
    CHECK(model.prior_probability() == doctest::Approx(0.625).epsilon(1e-9));
    CHECK(model.probability(vec1(60.0)) == doctest::Approx(0.625).epsilon(1e-9));
  }
}

TEST_CASE("separable 1-D data: mode equation, mirror symmetry, monotone probability and its limits") {
  // Failures at x < 0.3, successes at x > 0.7, as many of each: p̄ = 1/2, so m = 0 and mirroring x → 1 − x with
  // the labels swapped must give P(x) = 1 − P(1 − x) exactly.
  const std::vector<double> xs = {0.0, 0.1, 0.2, 0.25, 0.75, 0.8, 0.9, 1.0};
  std::vector<bool> ok = {false, false, false, false, true, true, true, true};
  FeasibilityModel model(1);
  REQUIRE(model.fit(column(xs), ok, vec1(0.3)));
  CHECK(std::abs(model.prior_mean()) < 1e-10);
  // The mode satisfies f̂ − m = K ∇log p(y | f̂) (R&W eq. 3.17), with K from an independent kernel object.
  kernels::ArdKernel kern(kernels::KernelType::Matern52, 1);
  Vec lp(2);
  lp << std::log(0.3 * model.hyper().lengthscale_factor), std::log(model.hyper().signal_std);
  kern.set_log_params(lp);
  Vec grad(8);
  for (Index i = 0; i < 8; ++i) grad(i) = bo::probit_terms(ok[static_cast<std::size_t>(i)] ? 1 : -1, model.mode()(i)).d1;
  const Vec residual = model.mode() - Vec::Constant(8, model.prior_mean()) - kern.matrix(column(xs)) * grad;
  CHECK(residual.cwiseAbs().maxCoeff() < 1e-7);

  std::vector<bool> mirrored(ok.size());
  std::vector<double> mxs(xs.size());
  for (std::size_t i = 0; i < xs.size(); ++i) {
    mxs[i] = 1.0 - xs[i];
    mirrored[i] = !ok[i];
  }
  FeasibilityModel mirror(1);
  REQUIRE(mirror.fit(column(mxs), mirrored, vec1(0.3)));
  for (double x = -0.2; x <= 1.2; x += 0.05)
    CHECK(model.probability(vec1(x)) == doctest::Approx(1.0 - mirror.probability(vec1(1.0 - x))).epsilon(1e-10));
  double previous = -1;
  for (double x = 0.2; x <= 0.8; x += 0.05) {
    const double p = model.probability(vec1(x));
    CHECK(p > previous);  // monotone across the gap between the classes
    previous = p;
  }
  CHECK(model.probability(vec1(0.5)) == doctest::Approx(0.5).epsilon(1e-10));  // the midpoint, by symmetry
  CHECK(model.probability(vec1(0.1)) < 0.2);
  CHECK(model.probability(vec1(0.9)) > 0.8);
  // Far away the classifier returns to its prior, P = p̄ = 1/2.
  CHECK(model.probability(vec1(50.0)) == doctest::Approx(0.5).epsilon(1e-9));
}

TEST_CASE("more failures at one θ lower P(success) there further") {
  double previous = 1;
  for (int repeats = 1; repeats <= 4; ++repeats) {
    std::vector<double> xs = {0.8, 0.9};
    std::vector<bool> ok = {true, true};
    for (int r = 0; r < repeats; ++r) {
      xs.push_back(0.2);
      ok.push_back(false);
    }
    FeasibilityModel model(1);
    REQUIRE(model.fit(column(xs), ok, vec1(0.2), false, {1.0, 2.0}));
    const double p = model.probability(vec1(0.2));
    CAPTURE(repeats);
    CHECK(p < previous);
    previous = p;
  }
  CHECK(previous < 0.2);  // four failures at the same θ: the default min_probability excludes it
}

TEST_CASE("the gradient of P(success | x) matches central differences (2-D, every grid hyperparameter)") {
  Rng rng(7);
  Mat X(14, 2);
  std::vector<bool> ok;
  for (Index i = 0; i < X.rows(); ++i) {
    X.row(i) = rng.uniform_vec(2).transpose();
    ok.push_back(X(i, 0) + 0.5 * X(i, 1) > 0.5);  // a slanted boundary
  }
  Vec ell(2);
  ell << 0.3, 0.5;
  for (const FeasibilityModel::Hyper& h : FeasibilityModel::grid()) {
    FeasibilityModel model(2);
    REQUIRE(model.fit(X, ok, ell, false, h));
    FunctionRef f(2, [&](const Vec& x, Vec* g) { return model.probability(x, g); });
    for (int t = 0; t < 5; ++t) {
      const Vec x = rng.uniform_vec(2);
      const GradientCheck c = check_gradient(f, x, 1e-6, 1e-8);
      CAPTURE(h.lengthscale_factor);
      CAPTURE(h.signal_std);
      CHECK(c.max_abs_error < 1e-7);
    }
  }
}

TEST_CASE("per-dimension lengthscales (ard): a slab failing in one coordinate is learned as a slab") {
  // 3-D, trials fail where x3 > 0.7 (the failure benchmark's Hartmann-6 slab in miniature), all of them in the
  // half x1 < 0.5. The evidence (R&W eq. 3.32) must rise along the coordinate ascent, the lengthscale of x3 end
  // shorter than those of x1 and x2, and the classifier must extrapolate the slab to the unexplored half x1 > 0.5,
  // which the common-factor model (the cost model's lengthscales, equal here) cannot.
  Rng rng(11);
  Mat X(40, 3);
  std::vector<bool> ok;
  for (Index i = 0; i < X.rows(); ++i) {
    X.row(i) = rng.uniform_vec(3).transpose();
    X(i, 0) *= 0.5;
    ok.push_back(X(i, 2) <= 0.7);
  }
  const Vec ell = Vec::Constant(3, 0.2);
  FeasibilityModel shared(3), ard(3);
  ard.set_ard(true);
  REQUIRE(shared.fit(X, ok, ell));
  REQUIRE(ard.fit(X, ok, ell));
  CHECK(ard.log_evidence() >= shared.log_evidence());  // the ascent starts at the shared grid's choice
  const Vec& f = ard.hyper().dim_factor;
  REQUIRE(f.size() == 3);
  CHECK(f(2) < f(0));
  CHECK(f(2) < f(1));
  // The fitted state is the chosen hyperparameters' (refitting them without selection gives the same P).
  FeasibilityModel again(3);
  REQUIRE(again.fit(X, ok, ell, false, ard.hyper()));
  for (int t = 0; t < 20; ++t) {
    Vec x = rng.uniform_vec(3);
    x(0) = 0.5 + 0.5 * x(0);  // the unexplored half
    CHECK(again.probability(x) == doctest::Approx(ard.probability(x)).epsilon(1e-12));
    if (x(2) > 0.85) {
      CHECK(ard.probability(x) < 0.5);
      CHECK(ard.probability(x) < shared.probability(x));
    }
    if (x(2) < 0.5) CHECK(ard.probability(x) > 0.5);
  }
  // A gradient check at the ARD hyperparameters (the dim factors enter the kernel's lengthscales only).
  FunctionRef p(3, [&](const Vec& x, Vec* g) { return ard.probability(x, g); });
  for (int t = 0; t < 5; ++t) CHECK(check_gradient(p, rng.uniform_vec(3), 1e-6, 1e-8).max_abs_error < 1e-7);
}

TEST_CASE("fit_failures: a failure among successes is not explained away as label noise") {
  // 1-D, successes every 0.05 on [0, 1] but at 0.55, where a trial failed: on the evidence alone the smoothest
  // explanation is a success everywhere and one noisy label, P(success) above 0.5 at the failed θ (the trial would
  // be suggested again). With set_fit_failures the chosen hyperparameters put that θ below 0.5 (session 37). The
  // cost model's lengthscale 0.23 is where the grid's best evidence reads the failure as noise while other grid
  // points fit it; the choice is checked against every grid point fitted on its own.
  std::vector<double> xs;
  std::vector<bool> ok;
  for (int i = 0; i <= 20; ++i) {
    xs.push_back(0.05 * i);
    ok.push_back(i != 11);
  }
  const Mat X = column(xs);
  FeasibilityModel plain(1), fitted(1);
  fitted.set_fit_failures(true);
  REQUIRE(plain.fit(X, ok, vec1(0.23)));
  REQUIRE(fitted.fit(X, ok, vec1(0.23)));
  CHECK(plain.probability(vec1(0.55)) > 0.5);  // the failure read as noise
  CHECK(fitted.probability(vec1(0.55)) < 0.5);
  CHECK(fitted.mode()(11) < 0);
  // The rule by brute force: the highest evidence among the grid points whose mode is negative at the failure.
  double best_evidence = -1e300;
  FeasibilityModel::Hyper expected{};
  int fitting = 0;
  for (const FeasibilityModel::Hyper& h : FeasibilityModel::grid()) {
    FeasibilityModel one(1);
    REQUIRE(one.fit(X, ok, vec1(0.23), false, h));
    if (one.mode()(11) >= 0) continue;
    ++fitting;
    if (one.log_evidence() > best_evidence) best_evidence = one.log_evidence(), expected = h;
  }
  REQUIRE(fitting > 0);
  REQUIRE(fitting < static_cast<int>(FeasibilityModel::grid().size()));
  CHECK(fitted.hyper().lengthscale_factor == expected.lengthscale_factor);
  CHECK(fitted.hyper().signal_std == expected.signal_std);
  CHECK(fitted.log_evidence() == doctest::Approx(best_evidence).epsilon(1e-12));
  CHECK(plain.log_evidence() > fitted.log_evidence());
  // The successes stay likely away from the failure (the dip is local, not the whole line).
  CHECK(fitted.probability(vec1(0.2)) > 0.8);
  CHECK(fitted.probability(vec1(0.9)) > 0.8);
  // Refitting gives the same choice (deterministic: a fixed grid, ties to the earlier candidate).
  FeasibilityModel again(1);
  again.set_fit_failures(true);
  REQUIRE(again.fit(X, ok, vec1(0.23)));
  CHECK(again.hyper().lengthscale_factor == fitted.hyper().lengthscale_factor);
  CHECK(again.hyper().signal_std == fitted.hyper().signal_std);
  CHECK(again.probability(vec1(0.55)) == fitted.probability(vec1(0.55)));

  // A failure with a success within 0.01 of it (the same θ failing and succeeding: a stochastic failure) is not
  // forced: the choice is the evidence's, as without the option.
  xs.push_back(0.555);
  ok.push_back(true);
  const Mat Y = column(xs);
  FeasibilityModel plain2(1), fitted2(1);
  fitted2.set_fit_failures(true);
  REQUIRE(plain2.fit(Y, ok, vec1(0.23)));
  REQUIRE(fitted2.fit(Y, ok, vec1(0.23)));
  CHECK(fitted2.hyper().lengthscale_factor == plain2.hyper().lengthscale_factor);
  CHECK(fitted2.hyper().signal_std == plain2.hyper().signal_std);
  CHECK(fitted2.probability(vec1(0.55)) == plain2.probability(vec1(0.55)));
}
