// Tests of the vhgp surrogate: the bound, its gradients and the predictive against the authors' reference
// numbers (testdata/, copied from shared/reference/vhgp), finite differences, fits, and determinism.
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "budgeted_objective.hpp"
#include "homoscedastic_init.hpp"
#include "kernel_library.hpp"
#include "varbo/errors.hpp"
#include "varbo/function.hpp"
#include "varbo/log.hpp"
#include "varbo/parallel.hpp"
#include "predictive_gradient_check.hpp"
#include "same_as_gp_check.hpp"
#include "varbo_test.hpp"
#include "vhgp_surrogate.hpp"

using namespace varbo;
using namespace varbo::vhgp;
using json = nlohmann::json;

namespace {

// The best bound on data_a (raw costs, SE kernels, jitter 1e-6, no hyperpriors) found while developing this test
// with 16 restarts; the reference README gives no number for the authors' own fits.
constexpr double kDataABestBound = -13.58064;

json load_json(const std::string& name) {
  std::ifstream in(std::string(VHGP_TESTDATA) + "/" + name);
  REQUIRE(in.good());
  return json::parse(in);
}

Dataset load_data_a() {
  std::ifstream in(std::string(VHGP_TESTDATA) + "/data_a.csv");
  REQUIRE(in.good());
  std::string line;
  std::getline(in, line);  // header i,x,u,e,y
  Dataset d = Dataset::empty(1);
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    std::stringstream ss(line);
    std::string cell;
    std::vector<double> v;
    while (std::getline(ss, cell, ',')) v.push_back(std::stod(cell));
    REQUIRE(v.size() == 5);
    d.add(Vec::Constant(1, v[1]), v[4]);
  }
  REQUIRE(d.size() == 20);
  return d;
}

Vec to_vec(const json& j) {
  Vec v(static_cast<Index>(j.size()));
  for (std::size_t i = 0; i < j.size(); ++i) v(static_cast<Index>(i)) = j[i].get<double>();
  return v;
}

double rel_err(double a, double ref) { return std::abs(a - ref) / std::max(std::abs(ref), 1e-300); }
double max_rel_err(const Vec& a, const Vec& ref) {
  double e = 0;
  for (Index i = 0; i < ref.size(); ++i) e = std::max(e, rel_err(a(i), ref(i)));
  return e;
}

/// The reference model: θ = [log ℓ_f, log σ_f, log ℓ_g, log σ_g, μ0], SE kernels, jitter 0 or 1e-6.
VhgpParams reference_params(const json& ref, const json& model) {
  const Vec theta = to_vec(model["theta"]);
  VhgpParams p;
  p.log_lambda = to_vec(ref["log_Lambda"]);
  p.theta_f = theta.segment(0, 2);
  p.theta_g = theta.segment(2, 2);
  p.mu0 = theta(4);
  return p;
}

/// The struct defaults these tests were written with, before VhgpConfig{} took the declared defaults (issue 12:
/// kernel_f matern52_ard, full_fit_growth 1.25): SE for f, every fit full, the noise model chosen at every fit and
/// warm fits joint (issue 10: select_every_fit false, warm_lambda_only true). Pinned so the tests keep their meaning
/// and their measured numbers (README of this folder).
VhgpConfig se_config() {
  VhgpConfig c;
  c.kernels.f = KernelType::SquaredExponential;
  c.kernels.g = KernelType::SquaredExponential;
  c.full_fit_growth = 1.0;
  c.select_every_fit = true;   // (defaults since issue 10's speed work: false, true)
  c.warm_lambda_only = false;
  c.homoscedastic_member = HomoscedasticMember::Vhgp;  // (default since branch vh14: gp)
  return c;
}

double model_jitter(const json& model) { return model["name"] == "A1_SE" ? 0.0 : 1e-6; }

std::shared_ptr<const Optimizer> fit_optimizer(const std::string& yaml = "ceres_lbfgs") {
  BuildContext ctx;
  ctx.dim = 1;
  return std::shared_ptr<const Optimizer>(test::registry().create<Optimizer>(yaml, ctx));
}

/// Random inputs in the unit cube and a heteroscedastic cost.
Dataset heteroscedastic_data(Index n, Index dim, std::uint64_t seed) {
  Rng rng(seed);
  Dataset d = Dataset::empty(dim);
  for (Index i = 0; i < n; ++i) {
    const Vec x = rng.uniform_vec(dim);
    d.add(x, std::sin(3.0 * x.sum()) + (0.05 + x(0)) * rng.normal());
  }
  return d;
}

}  // namespace

TEST_CASE("bound and every gradient component match the reference (A1_SE, A1j_SEjitter)") {
  const json ref = load_json("fixed_bound.json");
  const Dataset data = load_data_a();
  for (const auto& model : ref["models"]) {
    CAPTURE(model["name"].get<std::string>());
    const VhgpBound bound(data.X, data.y, VhgpKernels{KernelType::SquaredExponential,
                                                      KernelType::SquaredExponential, model_jitter(model)});
    const BoundValue b = bound.evaluate(reference_params(ref, model), true);
    REQUIRE(b.ok);
    const double eF = rel_err(b.F, model["F"].get<double>());
    const double eLL = max_rel_err(b.gradient.log_lambda, to_vec(model["grad_F_wrt_log_Lambda"]));
    const double eL = max_rel_err(b.gradient.lambda, to_vec(model["grad_F_wrt_Lambda"]));
    Vec theta_grad(5);
    theta_grad << b.gradient.theta_f, b.gradient.theta_g, b.gradient.mu0;
    const double eT = max_rel_err(theta_grad, to_vec(model["grad_F_wrt_theta"]));
    MESSAGE(model["name"].get<std::string>(), ": rel err F ", eF, ", dF/dlogLambda ", eLL, ", dF/dLambda ", eL,
            ", dF/dtheta ", eT);
    CHECK(eF < 1e-9);
    CHECK(eLL < 1e-9);
    CHECK(eL < 1e-9);
    CHECK(eT < 1e-9);
  }
}

TEST_CASE("predictive at the 5 reference points matches (a*, c*2, mu*, sigma*2, E, V)") {
  const json ref = load_json("fixed_bound.json");
  const Dataset data = load_data_a();
  for (const auto& model : ref["models"]) {
    CAPTURE(model["name"].get<std::string>());
    const double jitter = model_jitter(model);
    const VhgpParams p = reference_params(ref, model);
    const json& pred = model["predictions"];
    const Vec xs = to_vec(pred["x"]);

    // The latent predictive of the core posterior ...
    const VhgpBound bound(data.X, data.y, VhgpKernels{KernelType::SquaredExponential,
                                                      KernelType::SquaredExponential, jitter});
    BoundValue bv;
    const VhgpPosterior post = VhgpPosterior::condition(bound, p, &bv);
    REQUIRE(bv.ok);
    // ... and the same model through the Surrogate interface (no standardization, parameters given in cost
    // units as `varbo fit --no-optimize` does).
    VhgpConfig cfg = se_config();
    cfg.kernels.jitter = jitter;
    cfg.standardize = false;
    VhgpSurrogate s(1, cfg, nullptr);
    s.set_hyperparameters({{"lengthscale_f[0]", std::exp(p.theta_f(0))},
                           {"signal_std_f", std::exp(p.theta_f(1))},
                           {"lengthscale_g", std::exp(p.theta_g(0))},
                           {"signal_std_g", std::exp(p.theta_g(1))},
                           {"mu0", p.mu0}});
    s.set_state("log_lambda", p.log_lambda);
    const FitReport rep = s.condition(data);
    REQUIRE(rep.ok);
    CHECK(rel_err(rep.log_likelihood, model["F"].get<double>()) < 1e-9);

    double worst = 0;
    for (Index i = 0; i < xs.size(); ++i) {
      const std::size_t k = static_cast<std::size_t>(i);
      const LatentPrediction l = post.predict(Vec::Constant(1, xs(i)), false);
      const Prediction q = s.predict(Vec::Constant(1, xs(i)), false);
      const double e[] = {rel_err(l.a, pred["a_star"][k].get<double>()),
                          rel_err(l.c2, pred["c2_star"][k].get<double>()),
                          rel_err(l.mu, pred["mu_star"][k].get<double>()),
                          rel_err(l.s2, pred["sigma2_star"][k].get<double>()),
                          rel_err(q.mean, pred["E_y"][k].get<double>()),
                          rel_err(q.total_var(), pred["V_y"][k].get<double>()),
                          rel_err(q.latent_var, pred["c2_star"][k].get<double>()),
                          rel_err(q.log_noise_mean, pred["mu_star"][k].get<double>()),
                          rel_err(q.log_noise_var, pred["sigma2_star"][k].get<double>())};
      for (double v : e) {
        CHECK(v < 1e-9);
        worst = std::max(worst, v);
      }
    }
    MESSAGE(model["name"].get<std::string>(), ": worst relative error of the predictive ", worst);
  }
}

TEST_CASE("every gradient of the objective against finite differences at random parameters") {
  // Central differences with h = 1e-5 (relative to max(1, |x_i|)) on F + log prior. Tolerance 1e-6 relative to
  // max(|analytic|, |numeric|, 1e-3): below 1e-3 the round-off of the differences (~1e-16·|F|/h) dominates.
  for (const auto kf : {KernelType::SquaredExponential, KernelType::Matern52}) {
    for (const auto kg : {KernelType::SquaredExponential, KernelType::Matern52}) {
      for (const double jitter : {0.0, 1e-6}) {
        for (std::uint64_t seed = 1; seed <= 3; ++seed) {
          const Index dim = 2, n = 14;
          const Dataset d = heteroscedastic_data(n, dim, 100 + seed);
          const VhgpBound bound(d.X, d.y, VhgpKernels{kf, kg, jitter});
          VhgpHyperprior prior;  // enabled: its gradient is checked too
          const VhgpObjective obj(bound, prior);
          Rng rng(seed);
          VhgpParams p;
          p.log_lambda = Vec::Constant(n, std::log(0.5)) + 0.8 * rng.normal_vec(n);
          p.theta_f = Vec(dim + 1);
          p.theta_g = Vec(dim + 1);
          for (Index i = 0; i < dim; ++i) {
            p.theta_f(i) = std::log(rng.uniform(0.15, 1.0));
            p.theta_g(i) = std::log(rng.uniform(0.15, 1.0));
          }
          p.theta_f(dim) = std::log(rng.uniform(0.5, 2.0));
          p.theta_g(dim) = std::log(rng.uniform(0.3, 1.5));
          p.mu0 = rng.uniform(-4.0, 0.0);
          const GradientCheck c = check_gradient(obj, p.pack(), 1e-5, 1e-3);
          CAPTURE(kernels::kernel_type_name(kf));
          CAPTURE(kernels::kernel_type_name(kg));
          CAPTURE(jitter);
          CAPTURE(seed);
          CAPTURE(c.max_abs_error);
          CHECK(c.max_rel_error < 1e-6);
        }
      }
    }
  }
}

TEST_CASE("lambda-only objective gives the log-Lambda part of the gradient") {
  const Dataset d = heteroscedastic_data(10, 1, 7);
  const VhgpBound bound(d.X, d.y, VhgpKernels{});
  VhgpHyperprior prior;
  VhgpParams p;
  p.log_lambda = Vec::Constant(10, std::log(0.7));
  p.theta_f = Vec::Constant(2, std::log(0.4));
  p.theta_g = Vec::Constant(2, std::log(0.6));
  p.mu0 = -2;
  const VhgpObjective joint(bound, prior), lambda_only(bound, prior, p);
  Vec gj, gl;
  const double vj = joint.value(p.pack(), &gj), vl = lambda_only.value(p.log_lambda, &gl);
  CHECK(vj == vl);
  CHECK((gj.head(10) - gl).cwiseAbs().maxCoeff() == 0.0);
  CHECK(check_gradient(lambda_only, p.log_lambda).max_rel_error < 1e-6);
}

TEST_CASE("predictive gradients with respect to x against finite differences (cost units)") {
  for (const auto kf : {KernelType::SquaredExponential, KernelType::Matern52}) {
    const Index dim = 2;
    const Dataset d = heteroscedastic_data(15, dim, 42);
    VhgpConfig cfg = se_config();
    cfg.kernels.f = kf;
    cfg.kernels.g = kf == KernelType::Matern52 ? KernelType::SquaredExponential : KernelType::Matern52;
    VhgpSurrogate s(dim, cfg, nullptr);
    s.set_hyperparameters({{"lengthscale_f[0]", 0.3}, {"lengthscale_f[1]", 0.5}, {"signal_std_f", 1.2},
                           {"lengthscale_g", 0.4}, {"signal_std_g", 0.8}, {"mu0", -2.5}});
    Rng rng(3);
    s.set_state("log_lambda", Vec::Constant(15, std::log(0.5)) + 0.5 * rng.normal_vec(15));
    REQUIRE(s.condition(d).ok);
    check_predictive_x_gradients(s, dim, rng);
  }
}

TEST_CASE("fitting data_a from scratch (no hyperpriors, SE, jitter 1e-6, 16 restarts)") {
  const json ref = load_json("fixed_bound.json");
  const Dataset data = load_data_a();
  VhgpConfig cfg = se_config();
  cfg.kernels.jitter = 1e-6;
  cfg.restarts = 16;
  cfg.prior.enabled = false;
  cfg.standardize = false;  // the bound on the raw data, comparable with the authors' numbers
  // The paper's model: no selection of the constant-noise member (its bound here is −16.5, 2.9 below).
  cfg.noise_model = NoiseModel::Heteroscedastic;
  // Tight tolerances so that every restart runs to a stationary point.
  VhgpSurrogate s(1, cfg,
                  fit_optimizer("{type: ceres_lbfgs, max_iterations: 2000, function_tolerance: 1e-13, "
                                "gradient_tolerance: 1e-9, parameter_tolerance: 1e-12}"));
  Rng rng(2024);
  if (std::getenv("VHGP_DEBUG")) set_log_level(LogLevel::Debug);
  const FitReport rep = s.fit(data, rng);
  set_log_level(LogLevel::Info);
  MESSAGE("data_a fit: ", rep.report(), "; F = ", fmt::format("{:.10f}", rep.log_likelihood));
  std::string hp;
  for (const auto& h : s.hyperparameters()) hp += h.name + "=" + std::to_string(h.value) + " ";
  MESSAGE("hyperparameters: ", hp);
  REQUIRE(rep.ok);
  CHECK(rep.restarts == 16);
  CHECK(rep.log_prior == 0.0);
  CHECK(rep.objective == rep.log_likelihood);
  // Must beat the bound at the reference's fixed parameters by a wide margin ...
  const double fixed_F = ref["models"][1]["F"].get<double>();
  CHECK(rep.log_likelihood > fixed_F + 10.0);
  // ... and reach the best optimum found while developing this test (see the README of this folder).
  CHECK(rep.log_likelihood >= kDataABestBound - 1e-3);
  // At a (local) maximum the fixed-point condition Λ = Λ̂ holds: the gradient is small.
  const VhgpBound bound(data.X, data.y, cfg.kernels);
  VhgpParams p;
  p.log_lambda = s.state()[0].second;
  const auto h = s.hyperparameters();
  p.theta_f = Vec(2);
  p.theta_g = Vec(2);
  p.theta_f << std::log(h[0].value), std::log(h[1].value);
  p.theta_g << std::log(h[2].value), std::log(h[3].value);
  p.mu0 = h[4].value;
  const BoundValue b = bound.evaluate(p, true);
  REQUIRE(b.ok);
  CHECK(std::abs(b.F - rep.log_likelihood) < 1e-9 * std::abs(b.F));
  MESSAGE("gradient norm at the optimum: ", b.gradient.pack().norm());
  CHECK(b.gradient.pack().norm() < 1e-3);  // L-BFGS converges slowly along log Λ; F is flat to 1e-7 there
}

namespace {
Dataset sine_data(Index n, std::uint64_t seed, double sd_low, double sd_high) {
  Rng rng(seed);
  Dataset d = Dataset::empty(1);
  for (Index i = 0; i < n; ++i) {
    const double x = rng.uniform();
    d.add(Vec::Constant(1, x), std::sin(6.0 * x) + (sd_low + (sd_high - sd_low) * x) * rng.normal());
  }
  return d;
}
}  // namespace

TEST_CASE("the constant-noise member's bound is the homoscedastic GP's log marginal likelihood") {
  // Independent reference: log N(y | m, K + jitter·σ_f²I + σ_n²I) by Eigen in cost units (R&W eq. 2.30), at the
  // hyperparameters the homoscedastic fit reports. σ_g = 1e-4 leaves KL and tr Σ terms of order n·1e-8.
  const Dataset d = sine_data(60, 3, 0.2, 0.2);
  VhgpConfig cfg = se_config();
  cfg.kernels.f = KernelType::SquaredExponential;
  cfg.noise_model = NoiseModel::Homoscedastic;
  VhgpSurrogate s(1, cfg, fit_optimizer());
  Rng rng(4);
  const FitReport rep = s.fit(d, rng);
  REQUIRE(rep.ok);
  CHECK(s.homoscedastic_selected());
  std::map<std::string, double> h;
  for (const auto& p : s.hyperparameters()) h[p.name] = p.value;
  CHECK(h["signal_std_g"] == doctest::Approx(1e-4).epsilon(1e-12));
  const double ell = h["lengthscale_f[0]"], sf2 = h["signal_std_f"] * h["signal_std_f"], sn2 = std::exp(h["mu0"]);
  const Index n = d.size();
  Mat K(n, n);
  for (Index i = 0; i < n; ++i)
    for (Index j = 0; j < n; ++j) {
      const double r = d.X(i, 0) - d.X(j, 0);
      K(i, j) = sf2 * std::exp(-0.5 * r * r / (ell * ell)) + (i == j ? cfg.kernels.jitter * sf2 + sn2 : 0.0);
    }
  const Eigen::LLT<Mat> llt(K);
  const Vec r = d.y.array() - d.y.mean();
  const double log_ml = -0.5 * r.dot(llt.solve(r)) - llt.matrixLLT().diagonal().array().log().sum() -
                        0.5 * static_cast<double>(n) * std::log(2 * M_PI);
  MESSAGE("bound of the constant-noise member ", fmt::format("{:.10f}", rep.log_likelihood), ", GP log ML ",
          fmt::format("{:.10f}", log_ml));
  CHECK(std::abs(rep.log_likelihood - log_ml) < 1e-5);
}

TEST_CASE("noise_model auto keeps constant noise on homoscedastic data and the noise process on heteroscedastic data") {
  VhgpConfig cfg = se_config();  // noise_model auto (the default)
  REQUIRE(cfg.noise_model == NoiseModel::Auto);
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    CAPTURE(seed);
    // Noise sd 0.2 everywhere, then from 0.01 to 1 along x (100× across the domain).
    for (const double sd_high : {0.2, 1.0}) {
      const bool constant = sd_high == 0.2;
      VhgpSurrogate s(1, cfg, fit_optimizer());
      Rng rng(seed);
      const FitReport rep = s.fit(sine_data(60, seed, constant ? 0.2 : 0.01, sd_high), rng);
      REQUIRE(rep.ok);
      MESSAGE((constant ? "constant noise: " : "growing noise: "), rep.report());
      CHECK(s.homoscedastic_selected() == constant);
      // The constant-noise member has g ≡ μ0: a log-noise variance of exactly 0 (so acquisitions take their
      // closed homoscedastic forms), while the noise process keeps its predictive variance.
      const Prediction mid = s.predict(Vec::Constant(1, 0.5), true);
      CHECK((mid.log_noise_var == 0) == constant);
      CHECK((mid.d_log_noise_var.norm() == 0) == constant);
      if (constant) continue;
      // The selected model knows where the noise is: log noise variance at x = 0.95 well above x = 0.05.
      const Prediction lo = s.predict(Vec::Constant(1, 0.05), false), hi = s.predict(Vec::Constant(1, 0.95), false);
      CHECK(hi.log_noise_mean - lo.log_noise_mean > 3.0);
    }
  }
}

TEST_CASE("on constant-noise data the VHGP predictive approaches the homoscedastic GP's") {
  const Index n = 80;
  Rng rng(11);
  Dataset d = Dataset::empty(1);
  const double noise_sd = 0.2;
  for (Index i = 0; i < n; ++i) {
    const double x = rng.uniform();
    d.add(Vec::Constant(1, x), std::sin(6.0 * x) + noise_sd * rng.normal());
  }
  VhgpConfig cfg = se_config();  // hyperpriors on, standardized costs (the defaults)
  VhgpSurrogate s(1, cfg, fit_optimizer());
  Rng fit_rng(5);
  const FitReport rep = s.fit(d, fit_rng);
  REQUIRE(rep.ok);

  // Closed-form homoscedastic GP in the test (Eigen), at maximum-likelihood hyperparameters of k_f + σ_n² δ.
  const double m = d.y.mean();
  const double sd = std::sqrt((d.y.array() - m).square().sum() / (n - 1));
  const Vec ys = (d.y.array() - m) / sd;
  VhgpHyperprior no_prior;
  no_prior.enabled = false;
  Rng gp_rng(1);
  const HomoscedasticFit h =
      fit_homoscedastic(d.X, ys, *no_prior.configured(*kernels::make_stationary_ard(KernelType::SquaredExponential, 1), Process::F),
                        0.0, no_prior, *fit_optimizer(), gp_rng);
  REQUIRE(h.ok);
  const double ell = std::exp(h.theta_f(0)), sf2 = std::exp(2 * h.theta_f(1)), sn2 = std::exp(h.log_noise_var);
  auto k = [&](double a, double b) { return sf2 * std::exp(-0.5 * (a - b) * (a - b) / (ell * ell)); };
  Mat K(n, n);
  for (Index i = 0; i < n; ++i)
    for (Index j = 0; j < n; ++j) K(i, j) = k(d.X(i, 0), d.X(j, 0)) + (i == j ? sn2 : 0.0);
  const Eigen::LLT<Mat> llt(K);
  const Vec alpha = llt.solve(ys);
  double worst_mean = 0, worst_var = 0;
  for (int t = 0; t <= 20; ++t) {
    const double x = 0.05 + 0.9 * t / 20.0;
    Vec ks(n);
    for (Index i = 0; i < n; ++i) ks(i) = k(x, d.X(i, 0));
    const double gp_mean = m + sd * ks.dot(alpha);
    const double gp_var = sd * sd * (sf2 - ks.dot(llt.solve(ks)) + sn2);  // predictive variance of y*
    const Prediction p = s.predict(Vec::Constant(1, x), false);
    worst_mean = std::max(worst_mean, std::abs(p.mean - gp_mean) / noise_sd);
    worst_var = std::max(worst_var, std::abs(p.total_var() / gp_var - 1.0));
  }
  MESSAGE("constant noise: max |mean_VHGP - mean_GP| / noise sd = ", worst_mean,
          ", max |V_VHGP / V_GP - 1| = ", worst_var, "; GP noise sd ", sd * std::sqrt(sn2), " (true ", noise_sd, ")");
  CHECK(worst_mean < 0.1);
  CHECK(worst_var < 0.15);
}

TEST_CASE("fits are identical with 1 and 2 threads") {
  const Dataset d = heteroscedastic_data(30, 2, 9);
  auto run = [&](int threads) {
    ThreadLimit limit(threads);
    VhgpConfig cfg = se_config();
    cfg.restarts = 6;
    VhgpSurrogate s(2, cfg, fit_optimizer());
    Rng rng(77);
    const FitReport rep = s.fit(d, rng);
    REQUIRE(rep.ok);
    Vec out(7 + 30);
    const auto h = s.hyperparameters();
    for (int i = 0; i < 7; ++i) out(i) = h[static_cast<std::size_t>(i)].value;
    out.tail(30) = s.state()[0].second;
    return std::make_pair(out, rep.objective);
  };
  const auto one = run(1), two = run(2);
  CHECK(one.second == two.second);
  CHECK((one.first - two.first).cwiseAbs().maxCoeff() == 0.0);
}

TEST_CASE("warm start and a failed fit that keeps the last good model") {
  Dataset d = heteroscedastic_data(20, 1, 3);
  VhgpConfig cfg = se_config();
  cfg.restarts = 4;
  VhgpSurrogate s(1, cfg, fit_optimizer());
  Rng rng(1);
  const FitReport first = s.fit(d, rng);
  REQUIRE(first.ok);
  CHECK(s.ready());
  // A new point: the warm start pads log Λ with log ½ and the fit stays good.
  d.add(Vec::Constant(1, 0.37), 0.2);
  const FitReport second = s.fit(d, rng);
  REQUIRE(second.ok);
  CHECK(s.state()[0].second.size() == 21);
  const Prediction before = s.predict(Vec::Constant(1, 0.5), false);
  // A NaN cost makes every restart fail: the report says so and the model is unchanged.
  Dataset bad = d;
  bad.add(Vec::Constant(1, 0.9), std::nan(""));
  const FitReport failed = s.fit(bad, rng);
  CHECK_FALSE(failed.ok);
  CHECK(failed.message.find("kept the previous model") != std::string::npos);
  CHECK(s.ready());
  const Prediction after = s.predict(Vec::Constant(1, 0.5), false);
  CHECK(after.mean == before.mean);
  CHECK(after.total_var() == before.total_var());
  // Conditioning on bad data fails the same way.
  CHECK_FALSE(s.condition(bad).ok);
  CHECK(s.predict(Vec::Constant(1, 0.5), false).mean == before.mean);
}

TEST_CASE("the plugin component: options, given hyperparameters and log Lambda, errors") {
  BuildContext ctx;
  ctx.dim = 2;
  auto s = test::registry().create<Surrogate>(
      // noise_model heteroscedastic: on 12 points `auto` keeps the constant-noise member, whose log-noise
      // variance is 0, and this test checks that the noise process's predictive comes through the interface.
      "{type: vhgp, kernel_f: matern52_ard, noise_model: heteroscedastic, restarts: 2, hyperparameters: {lengthscale_f: [0.2, 0.4], "
      "signal_std_f: 2.0, mu0: -3.5}, log_lambda: [0.1, -0.2, 0.3]}",
      ctx);
  const auto h = s->hyperparameters();
  REQUIRE(h.size() == 7);
  CHECK(h[0].name == "lengthscale_f[0]");
  CHECK(h[0].value == doctest::Approx(0.2));
  CHECK(h[1].value == doctest::Approx(0.4));
  CHECK(h[2].name == "signal_std_f");
  CHECK(h[2].value == doctest::Approx(2.0));
  CHECK(h[6].name == "mu0");
  CHECK(h[6].value == doctest::Approx(-3.5));
  CHECK(s->signal_variance() == doctest::Approx(4.0));
  REQUIRE(s->state().size() == 1);
  CHECK(s->state()[0].first == "log_lambda");
  CHECK(s->state()[0].second.size() == 3);
  CHECK_THROWS_AS(s->set_hyperparameters({{"lengthscale_f[2]", 1.0}}), ConfigError);
  CHECK_THROWS_AS(s->set_hyperparameters({{"signal_std_g", -1.0}}), ConfigError);
  CHECK_THROWS_AS(s->set_state("nonsense", Vec::Zero(3)), ConfigError);
  CHECK_THROWS_AS(test::registry().create<Surrogate>("{type: vhgp, hyperparameters: {bogus: 1}}", ctx), ConfigError);
  CHECK_THROWS_AS(test::registry().create<Surrogate>("{type: vhgp, kernel_g: rbf}", ctx), ConfigError);
  CHECK_THROWS_AS(test::registry().create<Surrogate>("{type: vhgp, prior_mu0: [0, -1]}", ctx), ConfigError);
  // It fits and predicts with gradients through the interface.
  const Dataset d = heteroscedastic_data(12, 2, 4);
  Rng rng(3);
  REQUIRE(s->fit(d, rng).ok);
  const Prediction p = s->predict(Vec::Constant(2, 0.5), true);
  CHECK(p.has_gradient());
  CHECK(p.log_noise_var > 0);
  CHECK(std::isfinite(p.total_var()));
}

TEST_CASE("an evaluation budget records the best point and then reports it with a zero gradient") {
  // f(x) = −|x − 1|²: maximum 0 at x = 1.
  FunctionRef f(2, [](const Vec& x, Vec* g) {
    if (g) *g = -2.0 * (x.array() - 1.0).matrix();
    return -(x.array() - 1.0).square().sum();
  });
  const BudgetedObjective limited(f, 3);
  Vec g;
  CHECK(limited.value(Vec::Constant(2, 0.0), &g) == doctest::Approx(-2.0));
  CHECK(limited.value(Vec::Constant(2, 0.5), &g) == doctest::Approx(-0.5));
  CHECK(limited.value(Vec::Constant(2, -1.0), &g) == doctest::Approx(-8.0));
  // Budget spent: the best value seen, a zero gradient, whatever the point.
  CHECK(limited.value(Vec::Constant(2, 1.0), &g) == doctest::Approx(-0.5));
  CHECK(g.norm() == 0.0);
  CHECK(limited.best_value() == doctest::Approx(-0.5));
  CHECK((limited.best_x() - Vec::Constant(2, 0.5)).norm() == 0.0);
}

TEST_CASE("two-stage restarts reach the same optimum as running every start to convergence") {
  const Dataset data = load_data_a();
  VhgpConfig staged = se_config();
  staged.restarts = 8;
  VhgpConfig full = staged;
  full.restart_evaluations = 0;
  VhgpSurrogate a(1, staged, fit_optimizer("ceres_lbfgs"));
  VhgpSurrogate b(1, full, fit_optimizer("ceres_lbfgs"));
  Rng ra(5), rb(5);
  const FitReport fa = a.fit(data, ra), fb = b.fit(data, rb);
  REQUIRE(fa.ok);
  REQUIRE(fb.ok);
  MESSAGE("objective staged ", fa.objective, " vs all to convergence ", fb.objective);
  // ceres_lbfgs stops at a relative function change of 1e-6: the two agree to that order.
  CHECK(fa.objective >= fb.objective - 1e-3 * std::abs(fb.objective));
}

TEST_CASE("fixed_hyperparameters: a fit keeps the given hyperparameters and optimizes log Lambda only") {
  // Issue 10: `hyperparameters:` alone are the start of one restart (the fit may leave them); with
  // fixed_hyperparameters they are what every fit uses, and only the variational parameters move.
  BuildContext ctx;
  ctx.dim = 2;
  const std::string given =
      "hyperparameters: {lengthscale_f: [0.3, 0.5], signal_std_f: 1.7, lengthscale_g: [0.4, 0.6], signal_std_g: 0.9, "
      "mu0: -2.5}";
  auto fixed = test::registry().create<Surrogate>("{type: vhgp, fixed_hyperparameters: true, " + given + "}", ctx);
  auto free = test::registry().create<Surrogate>("{type: vhgp, " + given + "}", ctx);
  Dataset d = heteroscedastic_data(25, 2, 8);
  const auto start = fixed->hyperparameters();
  Rng r1(5), r2(5);
  const FitReport a = fixed->fit(d, r1);
  REQUIRE(a.ok);
  REQUIRE(free->fit(d, r2).ok);
  const auto after = fixed->hyperparameters(), moved = free->hyperparameters();
  REQUIRE(after.size() == start.size());
  double largest_move = 0;
  for (std::size_t i = 0; i < start.size(); ++i) {
    CHECK(after[i].value == doctest::Approx(start[i].value).epsilon(1e-12));
    largest_move = std::max(largest_move, std::abs(std::log(std::abs(moved[i].value / start[i].value))));
  }
  CHECK(largest_move > 0.1);  // the free fit does move them
  // log Λ is at a stationary point of the objective at those hyperparameters: F improved on Λ = ½ and ∂F/∂log Λ ≈ 0.
  REQUIRE(fixed->state()[0].first == "log_lambda");
  const Vec log_lambda = fixed->state()[0].second;
  REQUIRE(log_lambda.size() == 25);
  CHECK((log_lambda.array() - std::log(0.5)).abs().maxCoeff() > 1e-3);
  const double fitted = a.log_likelihood;
  fixed->set_state("log_lambda", Vec::Constant(25, std::log(0.5)));
  const FitReport at_half = fixed->condition(d);
  REQUIRE(at_half.ok);
  CHECK(fitted > at_half.log_likelihood);
  REQUIRE(fixed->state().size() == 3);  // log_lambda, bound_gradient, standardization
  const double grad_at_half = fixed->state()[1].second.head(25).cwiseAbs().maxCoeff();
  fixed->set_state("log_lambda", log_lambda);
  REQUIRE(fixed->condition(d).ok);
  const auto st = fixed->state();
  REQUIRE(st.size() == 3);
  CHECK(st[1].first == "bound_gradient");
  // The fit optimizer's default tolerances stop short of an exact zero: 5 % of the gradient at the start.
  CHECK(st[1].second.head(25).cwiseAbs().maxCoeff() < 0.05 * grad_at_half);
  // A second fit with a new point keeps them too.
  d.add(Vec::Constant(2, 0.5), 0.1);
  REQUIRE(fixed->fit(d, r1).ok);
  CHECK(fixed->hyperparameters()[0].value == doctest::Approx(0.3).epsilon(1e-12));
}

TEST_CASE("full_fit_growth: all restarts when N has grown by the factor, only the warm start in between") {
  VhgpConfig cfg = se_config();
  cfg.restarts = 4;
  cfg.full_fit_growth = 1.5;
  VhgpSurrogate s(1, cfg, fit_optimizer());
  const Dataset all = heteroscedastic_data(32, 1, 11);
  Rng rng(2);
  std::vector<int> restarts;
  for (Index n = 19; n <= 32; ++n) {
    Dataset d = Dataset::empty(1);
    for (Index i = 0; i < n; ++i) d.add(all.X.row(i).transpose(), all.y(i));
    const FitReport r = s.fit(d, rng);
    REQUIRE(r.ok);
    restarts.push_back(r.restarts);
  }
  // Up to N = 20 every fit is full; then N = 30 (≥ 1.5 × 20) is the next full one.
  CHECK(restarts == std::vector<int>{4, 4, 1, 1, 1, 1, 1, 1, 1, 1, 1, 4, 1, 1});
}

TEST_CASE("warm_evaluations: a fit between full fits stops the warm start after the budget, never below its start") {
  VhgpConfig cfg = se_config();
  cfg.restarts = 4;
  cfg.full_fit_growth = 10;  // every fit after the first on N > 20 is warm-only
  cfg.noise_model = NoiseModel::Heteroscedastic;  // (auto may keep the constant-noise member, fitted apart)
  const Dataset all = heteroscedastic_data(40, 1, 5);
  Dataset first = Dataset::empty(1), second = Dataset::empty(1);
  for (Index i = 0; i < 40; ++i) {
    if (i < 30) first.add(all.X.row(i).transpose(), all.y(i));
    second.add(all.X.row(i).transpose(), all.y(i));
  }
  // The same full fit on 30 points, then a warm-only fit on 40 (10 new points, so the optimum moves) to
  // convergence and with a budget of 3 evaluations.
  auto warm_fit = [&](int budget, double* start_objective) {
    VhgpConfig c = cfg;
    c.warm_evaluations = budget;
    VhgpSurrogate s(1, c, fit_optimizer());
    Rng rng(7);
    REQUIRE(s.fit(first, rng).ok);
    // The warm start on 40 points: the previous solution with log Λ = log ½ for the new points.
    VhgpSurrogate probe(1, c, fit_optimizer());
    probe.set_hyperparameters(s.hyperparameters());
    Vec ll = Vec::Constant(40, std::log(0.5));
    for (auto [name, value] : s.state())
      if (name == "log_lambda") ll.head(value.size()) = value;
    probe.set_state("log_lambda", ll);
    const FitReport at_start = probe.condition(second);
    REQUIRE(at_start.ok);
    *start_objective = at_start.log_likelihood;
    const FitReport r = s.fit(second, rng);
    REQUIRE(r.ok);
    CHECK(r.restarts == 1);
    return r.log_likelihood;
  };
  double start = 0, start2 = 0;
  const double converged = warm_fit(0, &start), budgeted = warm_fit(3, &start2);
  MESSAGE("bound at the warm start ", start, ", after 3 evaluations ", budgeted, ", converged ", converged);
  CHECK(start2 == doctest::Approx(start).epsilon(1e-12));
  CHECK(budgeted >= start - 1e-9);          // the budget keeps the best point seen, the start included
  CHECK(converged > budgeted + 1e-3);       // and it binds: 3 evaluations do not reach the optimum
}

TEST_CASE("select_every_fit false: between full fits only the family chosen at the last fit is refitted") {
  for (const double sd_high : {0.2, 1.0}) {  // constant noise (the GP member wins), noise growing 100× along x
    const bool constant = sd_high == 0.2;
    CAPTURE(constant);
    const Dataset all = sine_data(64, 1, constant ? 0.2 : 0.01, sd_high);
    for (const bool every : {true, false}) {
      CAPTURE(every);
      VhgpConfig cfg = se_config();
      cfg.restarts = 3;
      cfg.full_fit_growth = 10;  // one full fit (N = 60), then warm-only fits
      cfg.select_every_fit = every;
      VhgpSurrogate s(1, cfg, fit_optimizer());
      Rng rng(4);
      for (Index n = 60; n <= 64; ++n) {
        Dataset d = Dataset::empty(1);
        for (Index i = 0; i < n; ++i) d.add(all.X.row(i).transpose(), all.y(i));
        const FitReport r = s.fit(d, rng);
        REQUIRE(r.ok);
        CHECK(s.homoscedastic_selected() == constant);  // (as the noise_model auto test: seed 1 selects so)
        if (n == 60) {
          CHECK(r.restarts == 3);
          continue;
        }
        // Kept constant noise: no heteroscedastic restart at all; kept noise process: its warm start alone
        // (the homoscedastic GP is not refitted, which the report cannot show; the choice is what is checked).
        CHECK(r.restarts == (every || !constant ? 1 : 0));
        CHECK(r.message.find(constant ? "homoscedastic noise selected" : "heteroscedastic noise selected") !=
              std::string::npos);
      }
    }
  }
}

TEST_CASE("warm_lambda_only: a fit between full fits keeps the hyperparameters and maximizes the bound over log Lambda") {
  VhgpConfig cfg = se_config();
  cfg.restarts = 3;
  cfg.full_fit_growth = 10;
  cfg.noise_model = NoiseModel::Heteroscedastic;
  cfg.warm_lambda_only = true;
  const Dataset all = heteroscedastic_data(40, 1, 5);
  Dataset first = Dataset::empty(1);
  for (Index i = 0; i < 30; ++i) first.add(all.X.row(i).transpose(), all.y(i));
  VhgpSurrogate s(1, cfg, fit_optimizer());
  Rng rng(7);
  REQUIRE(s.fit(first, rng).ok);
  const Hyperparameters before = s.hyperparameters();
  // The warm start on 40 points: the previous solution, log Λ = log ½ for the new points.
  VhgpSurrogate probe(1, cfg, fit_optimizer());
  probe.set_hyperparameters(before);
  Vec ll = Vec::Constant(40, std::log(0.5));
  ll.head(30) = s.state()[0].second;
  probe.set_state("log_lambda", ll);
  const FitReport at_start = probe.condition(all);
  REQUIRE(at_start.ok);
  const FitReport r = s.fit(all, rng);
  REQUIRE(r.ok);
  CHECK(r.restarts == 1);
  const Hyperparameters after = s.hyperparameters();
  REQUIRE(after.size() == before.size());
  // Cost units: the standardization moved with the 10 new costs, the hyperparameters in cost units did not.
  for (std::size_t i = 0; i < after.size(); ++i) CHECK(after[i].value == doctest::Approx(before[i].value).epsilon(1e-12));
  CHECK(r.log_likelihood > at_start.log_likelihood + 1e-3);
  // log Λ at a stationary point of the bound (∂F/∂log Λ from condition(), model units): small against the start's.
  probe.set_state("log_lambda", s.state()[0].second);
  REQUIRE(probe.condition(all).ok);
  const auto grad_of = [](const VhgpSurrogate& m) {
    for (const auto& [name, v] : m.state())
      if (name == "bound_gradient") return Vec(v.head(40));
    return Vec();
  };
  VhgpSurrogate start_probe(1, cfg, fit_optimizer());
  start_probe.set_hyperparameters(before);
  start_probe.set_state("log_lambda", ll);
  REQUIRE(start_probe.condition(all).ok);
  CHECK(grad_of(probe).cwiseAbs().maxCoeff() < 0.05 * grad_of(start_probe).cwiseAbs().maxCoeff());
}

TEST_CASE("homoscedastic_member gp: where constant noise is selected, the vhgp predicts exactly as the gp surrogate") {
  // Both built through the registry as a study builds them, with one kernel given (kernel_f / kernel: matern52_ard,
  // the vhgp's default; `kernel_f: auto` is checked the same way in tests/test_vhgp_kernel_auto.cpp): the
  // vhgp with its default gp member, and the `gp` with its other defaults. Each gets its own stream from the same seed, and a fit of either draws one number from it,
  // so they stay in step over a sequence of fits N = 12 … 40 (the gp's full fits up to N = 20 and by growth 1.25,
  // warm-only fits in between). Reference: the gp surrogate itself; tolerance 1e-12 relative (the same arithmetic
  // on the same inputs: expected bit for bit).
  BuildContext ctx;
  ctx.dim = 2;
  auto v = test::registry().create<Surrogate>("{type: vhgp, kernel_f: matern52_ard}", ctx);
  auto g = test::registry().create<Surrogate>("{type: gp, kernel: matern52_ard}", ctx);
  Rng rv(7), rg(7);
  Rng data_rng(11);
  Dataset d = Dataset::empty(2);
  int selected = 0, fits = 0;
  const std::vector<Vec> probes = {Vec::Constant(2, 0.5), (Vec(2) << 0.1, 0.9).finished(),
                                   (Vec(2) << 0.73, 0.21).finished()};
  for (Index n = 1; n <= 40; ++n) {
    const Vec x = data_rng.uniform_vec(2);
    d.add(x, std::sin(3.0 * x.sum()) + 0.2 * data_rng.normal());  // constant noise sd 0.2
    if (n < 12) continue;
    const FitReport a = v->fit(d, rv);
    const FitReport b = g->fit(d, rg);
    REQUIRE(a.ok);
    REQUIRE(b.ok);
    ++fits;
    if (a.message.find("homoscedastic noise selected") == std::string::npos) continue;
    ++selected;
    CAPTURE(n);
    check_same_predictions(*v, *g, probes);
  }
  MESSAGE("constant noise selected in ", selected, " of ", fits, " fits");
  CHECK(selected >= fits - 2);  // homoscedastic data: the noise process is (almost) never worth its BIC penalty
  // An exact snapshot carries the gp member: a restored model predicts bit for bit as before.
  auto w = test::registry().create<Surrogate>("{type: vhgp, kernel_f: matern52_ard}", ctx);
  state_of(w.get())->restore_state(state_of(v.get())->save_state());
  for (const Vec& p : probes) CHECK(w->predict(p, false).mean == v->predict(p, false).mean);
  // Conditioning on one more point without a fit follows the gp's condition().
  const Vec x = data_rng.uniform_vec(2);
  d.add(x, std::sin(3.0 * x.sum()) + 0.2 * data_rng.normal());
  REQUIRE(v->condition(d).ok);
  REQUIRE(g->condition(d).ok);
  const auto close = [](double a, double b) { return std::abs(a - b) <= 1e-12 * std::max(1.0, std::abs(b)); };
  for (const Vec& p : probes) CHECK(close(v->predict(p, false).mean, g->predict(p, false).mean));
}

TEST_CASE("homoscedastic_member gp: the noise process is still found where the noise grows, with the vhgp's priors") {
  for (std::uint64_t seed : {1u, 2u}) {
    CAPTURE(seed);
    BuildContext ctx;
    ctx.dim = 1;
    auto v = test::registry().create<Surrogate>("{type: vhgp, homoscedastic_member: gp}", ctx);
    Rng rng(seed);
    const FitReport r = v->fit(sine_data(60, seed, 0.01, 1.0), rng);  // noise sd from 0.01 to 1 along x
    REQUIRE(r.ok);
    CHECK(r.message.find("heteroscedastic noise selected") != std::string::npos);
    const Prediction lo = v->predict(Vec::Constant(1, 0.05), false), hi = v->predict(Vec::Constant(1, 0.95), false);
    CHECK(hi.log_noise_mean - lo.log_noise_mean > 3.0);
    CHECK(hi.log_noise_var > 0);
  }
  // The default is the gp member (declared and struct default); a wrong value is an error.
  BuildContext ctx;
  ctx.dim = 1;
  CHECK(VhgpConfig{}.homoscedastic_member == HomoscedasticMember::Gp);
  std::string declared;
  for (const auto& o : test::registry().find(Kind::Surrogate, "vhgp").options)
    if (o.name == "homoscedastic_member") declared = o.default_yaml;
  CHECK(declared == "gp");
  CHECK_THROWS_AS(test::registry().create<Surrogate>("{type: vhgp, homoscedastic_member: gpp}", ctx), ConfigError);
}

TEST_CASE("a large offset of the costs does not change the model (costs of 1e15 + a few)") {
  // Session 25: the standardization took costs whose spread was under 1e-12 of their mean as constant (scale 1);
  // 1e15 + y with y spanning ~4 is still known to ~0.1, so a model of it must be the model of y moved by 1e15.
  // Heteroscedastic data ×100 (spread ~200 against the 1000 that 1e-12 · 1e15 called constant). Tolerances: the mean
  // within 0.5 (rounding of 1e15 + y: ulp 0.125), the predictive std within 5 %.
  Dataset base = heteroscedastic_data(40, 1, 8);
  base.y *= 100;
  VhgpConfig cfg;  // the declared defaults, with the vhgp's own constant-noise member (the gp's is tested in test_gp)
  cfg.homoscedastic_member = HomoscedasticMember::Vhgp;
  VhgpSurrogate reference(1, cfg, fit_optimizer());
  Rng r0(3);
  REQUIRE(reference.fit(base, r0).ok);
  Dataset shifted = base;
  shifted.y.array() += 1e15;
  VhgpSurrogate s(1, cfg, fit_optimizer());
  Rng r1(3);
  REQUIRE(s.fit(shifted, r1).ok);
  for (const double x : {0.1, 0.5, 0.9}) {
    CAPTURE(x);
    const Prediction p0 = reference.predict(Vec::Constant(1, x), false);
    const Prediction p = s.predict(Vec::Constant(1, x), false);
    CHECK(std::abs((p.mean - 1e15) - p0.mean) < 0.5);
    CHECK(p.total_std() == doctest::Approx(p0.total_std()).epsilon(0.05));
  }
}

TEST_CASE("conditioning a fitted model on more points (bo's batch) is silent; a given log_lambda of the wrong size warns") {
  // Red team, session 25: `varbo suggest --batch 3` with a vhgp printed "log_lambda has 9 values for 10 points" at
  // every suggestion: bo conditions the last fit on the pending points too. That is no user error.
  const Dataset d = heteroscedastic_data(12, 1, 5);
  Dataset more = d;
  more.add(Vec::Constant(1, 0.33), d.y.mean());
  more.add(Vec::Constant(1, 0.66), d.y.mean());
  const std::string log =
      (std::filesystem::temp_directory_path() / ("varbo_vhgp_batch_" + std::to_string(::getpid()) + ".log")).string();
  std::filesystem::remove(log);
  set_log_file(log);
  VhgpSurrogate s(1, VhgpConfig{}, fit_optimizer());
  Rng rng(2);
  REQUIRE(s.fit(d, rng).ok);
  CHECK(s.condition(more).ok);
  VhgpSurrogate given(1, VhgpConfig{}, fit_optimizer());
  given.set_state("log_lambda", Vec::Constant(3, -1.0));
  given.condition(d);
  set_log_file("");
  std::stringstream text_stream;
  text_stream << std::ifstream(log).rdbuf();
  const std::string text = text_stream.str();
  std::filesystem::remove(log);
  CHECK(text.find("log_lambda has 3 values for 12 points") != std::string::npos);
  CHECK(text.find("for 14 points") == std::string::npos);
}
