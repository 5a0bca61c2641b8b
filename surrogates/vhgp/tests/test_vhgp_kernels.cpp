// Tests of the vhgp surrogate with any kernel (issue 12, item 5): composite kernels for f and g (the original
// authors' SE + constant and SE + white noise among them) checked against a dense implementation of the bound and
// the predictive written from their definitions (vhgp.md §3, §6), every gradient against finite differences,
// the nesting of the fixed-kernel model, names, priors and boxes by role, and the option binding (item 2).
#include <cmath>
#include <map>
#include <yaml-cpp/yaml.h>

#include "kernel_library.hpp"
#include "varbo/errors.hpp"
#include "varbo/function.hpp"
#include "predictive_gradient_check.hpp"
#include "varbo_test.hpp"
#include "vhgp_surrogate.hpp"

using namespace varbo;
using namespace varbo::vhgp;

namespace {

KernelSpec sum_of(std::vector<KernelSpec> terms) {
  return KernelSpec([terms](Index dim) {
    std::vector<std::unique_ptr<Kernel>> built;
    for (const auto& t : terms) built.push_back(t.build(dim));
    return kernels::make_sum(std::move(built));
  });
}
KernelSpec product_of(std::vector<KernelSpec> terms) {
  return KernelSpec([terms](Index dim) {
    std::vector<std::unique_ptr<Kernel>> built;
    for (const auto& t : terms) built.push_back(t.build(dim));
    return kernels::make_product(std::move(built));
  });
}
const KernelSpec kConstant{KernelMaker(kernels::make_constant)};
const KernelSpec kWhite{KernelMaker(kernels::make_white)};
const KernelSpec kLinear{KernelMaker(kernels::make_linear)};
const KernelSpec kRationalQuadratic{KernelMaker(kernels::make_rational_quadratic)};

/// The authors' defaults (vhgpr_ui.m): f = SE + constant, g = SE + white noise.
VhgpKernels authors_kernels(double jitter) {
  return VhgpKernels{sum_of({KernelType::SquaredExponential, kConstant}),
                     sum_of({KernelType::SquaredExponential, kWhite}), jitter};
}

Dataset heteroscedastic_data(Index n, Index dim, std::uint64_t seed) {
  Rng rng(seed);
  Dataset d = Dataset::empty(dim);
  for (Index i = 0; i < n; ++i) {
    const Vec x = rng.uniform_vec(dim);
    d.add(x, std::sin(3.0 * x.sum()) + (0.05 + x(0)) * rng.normal());
  }
  return d;
}

/// Random log values around plausible magnitudes, by role.
Vec random_theta(const Kernel& k, Rng& rng) {
  Vec t(k.num_params());
  for (Index j = 0; j < t.size(); ++j) {
    switch (k.parameters()[static_cast<std::size_t>(j)].role) {
      case KernelParameterRole::Lengthscale: t(j) = std::log(rng.uniform(0.15, 1.0)); break;
      case KernelParameterRole::Amplitude: t(j) = std::log(rng.uniform(0.4, 1.5)); break;
      case KernelParameterRole::Noise: t(j) = std::log(rng.uniform(0.1, 0.6)); break;
      case KernelParameterRole::Shape: t(j) = std::log(rng.uniform(0.5, 3.0)); break;
    }
  }
  return t;
}

VhgpParams random_params(const VhgpBound& bound, Rng& rng) {
  VhgpParams p;
  p.log_lambda = Vec::Constant(bound.size(), std::log(0.5)) + 0.8 * rng.normal_vec(bound.size());
  p.theta_f = random_theta(bound.f_form(), rng);
  p.theta_g = random_theta(bound.g_form(), rng);
  p.mu0 = rng.uniform(-4.0, 0.0);
  return p;
}

double se(const Vec& a, const Vec& b, double ell, double sf2) {
  return sf2 * std::exp(-0.5 * (a - b).squaredNorm() / (ell * ell));
}

/// The authors' model written out by hand: k_f = SE(ℓ_f, σ_f) + c², k_g = SE(ℓ_g, σ_g) + s_n² δ (on the training
/// points and in k**, not between a new point and the data), each training matrix with jitter·diag K added.
struct DenseAuthorsModel {
  double ell_f, sf2, c2, ell_g, sg2, sn2, mu0, jitter;
  Mat X;
  Vec y, lambda;

  double kf(const Vec& a, const Vec& b) const { return se(a, b, ell_f, sf2) + c2; }
  double kg(const Vec& a, const Vec& b) const { return se(a, b, ell_g, sg2); }
  Mat train(bool f) const {
    const Index n = X.rows();
    Mat K(n, n);
    for (Index i = 0; i < n; ++i)
      for (Index j = 0; j < n; ++j) {
        const Vec a = X.row(i).transpose(), b = X.row(j).transpose();
        K(i, j) = f ? kf(a, b) : kg(a, b) + (i == j ? sn2 : 0.0);
      }
    K.diagonal() *= 1.0 + jitter;
    return K;
  }
  /// F = log N(y | 0, K_f + R) − KL(N(μ, Σ) ‖ N(μ0 1, K_g)) − ¼ tr Σ with Σ = (K_g⁻¹ + Λ)⁻¹, μ = K_g(Λ − ½) + μ0
  /// (vhgp.md §1, §3), by dense inverses and log-determinants.
  double bound() const {
    const Index n = X.rows();
    const Mat Kf = train(true), Kg = train(false);
    const Mat Sigma = (Kg.inverse() + Mat(lambda.asDiagonal())).inverse();
    const Vec mu = Kg * (lambda.array() - 0.5).matrix() + Vec::Constant(n, mu0);
    const Vec r = (mu - 0.5 * Sigma.diagonal()).array().exp();
    const Mat A = Kf + Mat(r.asDiagonal());
    const Eigen::LLT<Mat> la(A), lg(Kg), ls(Sigma);
    const double logdet_a = 2.0 * la.matrixLLT().diagonal().array().log().sum();
    const double log_n = -0.5 * y.dot(la.solve(y)) - 0.5 * logdet_a - 0.5 * n * std::log(2.0 * M_PI);
    const Vec dm = mu - Vec::Constant(n, mu0);
    const double kl = 0.5 * ((lg.solve(Sigma)).trace() + dm.dot(lg.solve(dm)) - n +
                             2.0 * lg.matrixLLT().diagonal().array().log().sum() -
                             2.0 * ls.matrixLLT().diagonal().array().log().sum());
    return log_n - kl - 0.25 * Sigma.trace();
  }
  /// (a*, c*², μ*, σ*²) of vhgp.md §6 by dense solves.
  Vec predict(const Vec& x) const {
    const Index n = X.rows();
    const Mat Kf = train(true), Kg = train(false);
    const Mat Sigma = (Kg.inverse() + Mat(lambda.asDiagonal())).inverse();
    const Vec mu = Kg * (lambda.array() - 0.5).matrix() + Vec::Constant(n, mu0);
    const Vec r = (mu - 0.5 * Sigma.diagonal()).array().exp();
    const Mat A = Kf + Mat(r.asDiagonal());
    Vec kfs(n), kgs(n);
    for (Index i = 0; i < n; ++i) {
      kfs(i) = kf(x, X.row(i).transpose());
      kgs(i) = kg(x, X.row(i).transpose());
    }
    const Mat B = Kg + Mat(lambda.cwiseInverse().asDiagonal());
    Vec out(4);
    out << kfs.dot(A.ldlt().solve(y)), (sf2 + c2) * (1.0 + jitter) - kfs.dot(A.ldlt().solve(kfs)),
        kgs.dot((lambda.array() - 0.5).matrix()) + mu0, (sg2 + sn2) * (1.0 + jitter) - kgs.dot(B.ldlt().solve(kgs));
    return out;
  }
};

}  // namespace

TEST_CASE("the authors' kernels (f: SE + constant, g: SE + white): bound and predictive match a dense implementation") {
  // Independent reference: the definitions of F and of the predictive evaluated with dense inverses (no B matrix,
  // no rescaling, no triangular kernels), at the sizes of the reference data set (N = 20) in 1-D and 2-D.
  for (const Index dim : {1, 2}) {
    for (const double jitter : {0.0, 1e-6}) {
      CAPTURE(dim);
      CAPTURE(jitter);
      const Dataset d = heteroscedastic_data(20, dim, 5 + static_cast<std::uint64_t>(dim));
      const VhgpBound bound(d.X, d.y, authors_kernels(jitter));
      // Parameter tables: terms[0] = SE (ℓ_1..D, σ), terms[1] = constant (σ_c) or white (σ_n).
      REQUIRE(bound.num_f() == dim + 2);
      REQUIRE(bound.num_g() == dim + 2);
      Rng rng(17);
      VhgpParams p = random_params(bound, rng);
      p.theta_f.head(dim).setConstant(std::log(0.3));  // the hand-written model is isotropic
      p.theta_g.head(dim).setConstant(std::log(0.45));
      const DenseAuthorsModel ref{0.3, std::exp(2 * p.theta_f(dim)), std::exp(2 * p.theta_f(dim + 1)), 0.45,
                                  std::exp(2 * p.theta_g(dim)), std::exp(2 * p.theta_g(dim + 1)), p.mu0, jitter,
                                  d.X, d.y, p.log_lambda.array().exp()};
      const BoundValue b = bound.evaluate(p, false);
      REQUIRE(b.ok);
      const double F_ref = ref.bound();
      MESSAGE("d = ", dim, ", jitter ", jitter, ": F = ", b.F, ", dense ", F_ref, ", rel. diff ",
              std::abs(b.F - F_ref) / std::abs(F_ref));
      CHECK(std::abs(b.F - F_ref) < 1e-9 * std::abs(F_ref));
      BoundValue cv;
      const VhgpPosterior post = VhgpPosterior::condition(bound, p, &cv);
      REQUIRE(cv.ok);
      double worst = 0;
      for (int t = 0; t < 5; ++t) {
        const Vec x = rng.uniform_vec(dim);
        const LatentPrediction l = post.predict(x, false);
        const Vec r = ref.predict(x);
        const double got[] = {l.a, l.c2, l.mu, l.s2};
        for (int k = 0; k < 4; ++k) {
          CAPTURE(k);
          const double e = std::abs(got[k] - r(k)) / std::max(1.0, std::abs(r(k)));
          CHECK(e < 1e-9);
          worst = std::max(worst, e);
        }
      }
      MESSAGE("worst error of (a*, c*2, mu*, sigma*2) at 5 points: ", worst);
    }
  }
}

TEST_CASE("a one-term sum gives the bound and gradient of its term (the composite path adds nothing)") {
  const Dataset d = heteroscedastic_data(15, 2, 3);
  for (const double jitter : {0.0, 1e-6}) {
    const VhgpBound plain(d.X, d.y, VhgpKernels{KernelType::Matern52, KernelType::SquaredExponential, jitter});
    const VhgpBound wrapped(d.X, d.y,
                            VhgpKernels{sum_of({KernelType::Matern52}), sum_of({KernelType::SquaredExponential}), jitter});
    Rng rng(4);
    const VhgpParams p = random_params(plain, rng);
    const BoundValue a = plain.evaluate(p, true), b = wrapped.evaluate(p, true);
    REQUIRE(a.ok);
    REQUIRE(b.ok);
    CHECK(std::abs(a.F - b.F) <= 1e-14 * std::abs(a.F));
    CHECK((a.gradient.pack() - b.gradient.pack()).cwiseAbs().maxCoeff() <= 1e-12 * a.gradient.pack().cwiseAbs().maxCoeff());
  }
}

TEST_CASE("every gradient of the objective against finite differences with composite kernels for f and g") {
  // As the ARD test of test_vhgp.cpp: central differences h = 1e-5 on F + log prior (priors by role), tolerance
  // 1e-6 relative to max(|analytic|, |numeric|, 1e-3).
  struct Case {
    const char* name;
    VhgpKernels kernels;
  };
  const std::vector<Case> cases = {
      {"f SE + constant, g SE + white (the authors')", authors_kernels(0.0)},
      {"f Matern-3/2 x linear, g RQ + white", VhgpKernels{product_of({KernelType::Matern32, kLinear}),
                                                          sum_of({kRationalQuadratic, kWhite}), 0.0}},
      {"f (SE x linear) + Matern-5/2, g Matern-1/2 + constant",
       VhgpKernels{sum_of({product_of({KernelType::SquaredExponential, kLinear}), KernelType::Matern52}),
                   sum_of({KernelType::Matern12, kConstant}), 0.0}},
  };
  for (const auto& c : cases) {
    for (const double jitter : {0.0, 1e-6}) {
      for (std::uint64_t seed = 1; seed <= 2; ++seed) {
        CAPTURE(c.name);
        CAPTURE(jitter);
        CAPTURE(seed);
        const Dataset d = heteroscedastic_data(14, 2, 200 + seed);
        VhgpKernels k = c.kernels;
        k.jitter = jitter;
        const VhgpBound bound(d.X, d.y, k);
        const VhgpHyperprior prior;  // enabled: the role priors' gradients are checked too
        const VhgpObjective obj(bound, prior);
        Rng rng(seed);
        const GradientCheck g = check_gradient(obj, random_params(bound, rng).pack(), 1e-5, 1e-3);
        CAPTURE(g.max_abs_error);
        CHECK(g.max_rel_error < 1e-6);
      }
    }
  }
}

TEST_CASE("predictive x-gradients with composite kernels (a linear term: k** depends on x)") {
  const Index dim = 2;
  const Dataset d = heteroscedastic_data(15, dim, 42);
  VhgpConfig cfg;
  cfg.kernels.f = sum_of({KernelType::SquaredExponential, kLinear});
  cfg.kernels.g = sum_of({product_of({KernelType::Matern52, kLinear}), kWhite});
  VhgpSurrogate s(dim, cfg, nullptr);
  Rng rng(3);
  Hyperparameters h;
  for (const auto& p : s.hyperparameters()) h.push_back({p.name, p.name == "mu0" ? -2.5 : rng.uniform(0.3, 0.8)});
  s.set_hyperparameters(h);
  s.set_state("log_lambda", Vec::Constant(15, std::log(0.5)) + 0.5 * rng.normal_vec(15));
  REQUIRE(s.condition(d).ok);
  check_predictive_x_gradients(s, dim, rng);
}

TEST_CASE("names, cost units, priors and boxes follow each parameter's role") {
  VhgpConfig cfg;
  cfg.kernels = authors_kernels(1e-11);
  cfg.prior.lengthscale_f = {std::log(0.7), 1.1};
  cfg.prior.signal_f = {std::log(2.0), 0.9};
  cfg.prior.lengthscale_g = {std::log(0.6), 1.3};
  cfg.prior.signal_g = {std::log(0.5), 0.8};
  const VhgpSurrogate s(2, cfg, nullptr);
  std::vector<std::string> names;
  for (const auto& h : s.hyperparameters()) names.push_back(h.name);
  CHECK(names == std::vector<std::string>{"terms[0].lengthscale_f[0]", "terms[0].lengthscale_f[1]",
                                          "terms[0].signal_std_f", "terms[1].signal_std_f",
                                          "terms[0].lengthscale_g[0]", "terms[0].lengthscale_g[1]",
                                          "terms[0].signal_std_g", "terms[1].noise_std_g", "mu0"});
  // Priors: lengthscales and amplitudes (the constant's σ_c too) take the vhgp's options; the white term keeps the
  // kernel's own noise prior.
  const auto& f = s.f_form().parameters();
  const auto& g = s.g_form().parameters();
  CHECK(f[0].prior.mean == cfg.prior.lengthscale_f.mean);
  CHECK(f[2].prior.sd == cfg.prior.signal_f.sd);
  CHECK(f[3].prior.mean == cfg.prior.signal_f.mean);
  CHECK(g[1].prior.sd == cfg.prior.lengthscale_g.sd);
  CHECK(g[2].prior.mean == cfg.prior.signal_g.mean);
  CHECK(g[3].prior.mean == kernels::noise_parameter().prior.mean);
  CHECK(g[2].lower == 1e-4);  // σ_g's box reaches down to the constant-noise member
  CHECK(f[3].upper == 1e2);
  // Cost units: amplitudes of f scale with the costs, g's do not. Hyperparameters given in cost units
  // condition the same model on y and on 10·y + 3 with the f amplitudes ×10 and μ0 + 2 log 10.
  const Dataset d = heteroscedastic_data(12, 2, 9);
  Dataset scaled = d;
  scaled.y = 10.0 * d.y.array() + 3.0;
  VhgpSurrogate a(2, cfg, nullptr), b(2, cfg, nullptr);
  const Hyperparameters base = {{"terms[0].lengthscale_f", 0.4}, {"terms[0].signal_std_f", 1.2},
                                {"terms[1].signal_std_f", 0.3},  {"terms[0].lengthscale_g", 0.5},
                                {"terms[0].signal_std_g", 0.7},  {"terms[1].noise_std_g", 0.2},
                                {"mu0", -3.0}};
  Hyperparameters times10 = base;
  times10[1].value *= 10;
  times10[2].value *= 10;
  times10[6].value += 2 * std::log(10.0);
  a.set_hyperparameters(base);
  b.set_hyperparameters(times10);
  const Vec log_lambda = Vec::Constant(12, std::log(0.6));
  a.set_state("log_lambda", log_lambda);
  b.set_state("log_lambda", log_lambda);
  REQUIRE(a.condition(d).ok);
  REQUIRE(b.condition(scaled).ok);
  const Vec x = Vec::Constant(2, 0.3);
  const Prediction pa = a.predict(x, false), pb = b.predict(x, false);
  CHECK(pb.mean == doctest::Approx(10.0 * pa.mean + 3.0).epsilon(1e-10));
  CHECK(pb.total_var() == doctest::Approx(100.0 * pa.total_var()).epsilon(1e-10));
  CHECK(b.signal_variance() == doctest::Approx(100.0 * (1.2 * 1.2 + 0.3 * 0.3)).epsilon(1e-12));
  CHECK_THROWS_AS(a.set_hyperparameters({{"terms[2].signal_std_f", 1.0}}), ConfigError);
  CHECK_THROWS_AS(a.set_hyperparameters({{"terms[1].noise_std_g", -1.0}}), ConfigError);
}

TEST_CASE("the authors' model nests the fixed-kernel one: fitted from its optimum it ends at least as high") {
  // SE alone is SE + constant with σ_c → 0 and SE + white with σ_n → 0: at σ_c = σ_n = 1e-4 the bound is the SE
  // model's to ~1e-6, and a fit warm-started there (σ_c clamped to its box floor 1e-3·std(y)) can only go up.
  const Dataset d = heteroscedastic_data(25, 1, 21);
  VhgpConfig se_model;
  se_model.kernels = VhgpKernels{KernelType::SquaredExponential, KernelType::SquaredExponential, 1e-11};
  se_model.restarts = 4;
  se_model.prior.enabled = false;
  se_model.noise_model = NoiseModel::Heteroscedastic;
  BuildContext ctx;
  ctx.dim = 1;
  std::shared_ptr<const Optimizer> opt(test::registry().create<Optimizer>("ceres_lbfgs", ctx));
  VhgpSurrogate a(1, se_model, opt);
  Rng rng(1);
  const FitReport fa = a.fit(d, rng);
  REQUIRE(fa.ok);
  std::map<std::string, double> h;
  for (const auto& p : a.hyperparameters()) h[p.name] = p.value;

  VhgpConfig authors = se_model;
  authors.kernels = authors_kernels(1e-11);
  VhgpSurrogate b(1, authors, opt);
  b.set_hyperparameters({{"terms[0].lengthscale_f[0]", h["lengthscale_f[0]"]},
                         {"terms[0].signal_std_f", h["signal_std_f"]},
                         {"terms[1].signal_std_f", 1e-4},
                         {"terms[0].lengthscale_g[0]", h["lengthscale_g[0]"]},
                         {"terms[0].signal_std_g", h["signal_std_g"]},
                         {"terms[1].noise_std_g", 1e-4},
                         {"mu0", h["mu0"]}});
  b.set_state("log_lambda", a.state()[0].second);
  const FitReport at = b.condition(d);
  REQUIRE(at.ok);
  MESSAGE("SE fit: F = ", fa.log_likelihood, "; SE + constant / SE + white at it: ", at.log_likelihood);
  CHECK(std::abs(at.log_likelihood - fa.log_likelihood) < 1e-5 * std::abs(fa.log_likelihood));
  Rng rng2(1);
  const FitReport fb = b.fit(d, rng2);
  REQUIRE(fb.ok);
  MESSAGE("SE + constant / SE + white fit: F = ", fb.log_likelihood, ", ", fb.report());
  CHECK(fb.log_likelihood >= at.log_likelihood - 1e-5 * std::abs(at.log_likelihood));
}

TEST_CASE("the plugin: composite kernels in YAML, the hyperparameter map, errors and --no-optimize completeness") {
  BuildContext ctx;
  ctx.dim = 2;
  const std::string kernels =
      "kernel_f: {type: sum, terms: [se_ard, constant]}, kernel_g: {type: sum, terms: [se_ard, white]}";
  auto s = test::registry().create<Surrogate>(
      "{type: vhgp, " + kernels + ", restarts: 2, hyperparameters: {'terms[0].lengthscale_f': [0.2, 0.4], "
      "'terms[1].signal_std_f': 0.5, 'terms[1].noise_std_g': 0.3}}", ctx);
  std::map<std::string, double> h;
  for (const auto& p : s->hyperparameters()) h[p.name] = p.value;
  CHECK(h.size() == 9);
  CHECK(h["terms[0].lengthscale_f[1]"] == doctest::Approx(0.4));
  CHECK(h["terms[1].signal_std_f"] == doctest::Approx(0.5));
  CHECK(h["terms[1].noise_std_g"] == doctest::Approx(0.3));
  CHECK_THROWS_AS(test::registry().create<Surrogate>("{type: vhgp, " + kernels + ", hyperparameters: {lengthscale_f: 1}}", ctx),
                  ConfigError);
  CHECK_THROWS_AS(test::registry().create<Surrogate>("{type: vhgp, kernel_f: {type: sum, terms: []}}", ctx), ConfigError);
  // Conditioning without a fit needs every one of the nine (GivenParameters, item 8).
  const Dataset d = heteroscedastic_data(12, 2, 4);
  CHECK_THROWS_WITH_AS(s->condition(d), doctest::Contains("missing: terms[0].signal_std_f"), ConfigError);
  CHECK_THROWS_WITH_AS(s->condition(d),
                       doctest::Contains("expected {'terms[0].lengthscale_f': [2 values], 'terms[0].signal_std_f', "
                                         "'terms[1].signal_std_f', 'terms[0].lengthscale_g': [2 values]"),
                       ConfigError);
  Rng rng(3);
  const FitReport r = s->fit(d, rng);
  REQUIRE(r.ok);
  const Prediction p = s->predict(Vec::Constant(2, 0.5), true);
  CHECK(p.has_gradient());
  CHECK(std::isfinite(p.total_var()));
}

TEST_CASE("options: a default-built vhgp is VhgpConfig{} (declared defaults = struct defaults)") {
  // Item 2: the declared defaults are what users get and VhgpConfig{} agrees. Every option bound through the
  // OptionSet takes its declared default from the struct; the kernels (components) are checked here through the
  // model itself: the same given parameters condition to the same predictions (SE and Matérn-5/2 differ).
  BuildContext ctx;
  ctx.dim = 2;
  const std::string given =
      "hyperparameters: {lengthscale_f: [0.3, 0.5], signal_std_f: 1.7, lengthscale_g: [0.4, 0.6], signal_std_g: 0.9, "
      "mu0: -2.5}, log_lambda: [-0.5, -0.9, -0.6, -0.7, -0.8, -0.4, -0.7, -0.6, -0.5, -0.9]";
  auto from_yaml = test::registry().create<Surrogate>("{type: vhgp, " + given + "}", ctx);
  VhgpSurrogate direct(2, VhgpConfig{}, nullptr);
  direct.set_hyperparameters(from_yaml->hyperparameters());
  direct.set_state("log_lambda", from_yaml->state()[0].second);
  const Dataset d = heteroscedastic_data(10, 2, 6);
  const FitReport ra = from_yaml->condition(d), rb = direct.condition(d);
  REQUIRE(ra.ok);
  REQUIRE(rb.ok);
  CHECK(ra.objective == rb.objective);  // the prior (prior_* options) enters the objective
  const Prediction a = from_yaml->predict(Vec::Constant(2, 0.35), false), b = direct.predict(Vec::Constant(2, 0.35), false);
  CHECK(a.mean == b.mean);
  CHECK(a.total_var() == b.total_var());
  // The declarations read back to the struct's values exactly (the μ0 prior used to be declared to 10 digits).
  const ComponentInfo& info = test::registry().find(Kind::Surrogate, "vhgp");
  std::map<std::string, std::string> def;
  for (const auto& o : info.options) def[o.name] = o.default_yaml;
  const VhgpConfig c;
  CHECK(def["full_fit_growth"] == "1.25");
  CHECK(c.full_fit_growth == 1.25);
  CHECK(def["warm_final_refit"] == "true");
  CHECK(def["select_every_fit"] == "false");
  CHECK(def["warm_lambda_only"] == "true");
  CHECK(c.warm_final_refit);
  CHECK_FALSE(c.select_every_fit);
  CHECK(c.warm_lambda_only);
  CHECK(def["kernel_f"] == "matern52_ard");  // `auto` is an option (test_vhgp_kernel_auto.cpp), not the default
  const YAML::Node mu0 = YAML::Load(def["prior_mu0"]);
  CHECK(mu0[0].as<double>() == c.prior.mu0.mean);
  CHECK(mu0[1].as<double>() == c.prior.mu0.sd);
}
