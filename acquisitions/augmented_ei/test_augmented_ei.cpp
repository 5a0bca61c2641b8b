// Tests of the augmented EI: closed form of each factor, the incumbent rule, the preference for low noise that
// motivates it, finite-difference gradients (homoscedastic and heteroscedastic predictions, a GP's empty
// log-noise gradients), and the plugin's options.
#include <cmath>
#include <functional>

#include "augmented_ei.hpp"
#include "varbo/errors.hpp"
#include "varbo/math.hpp"
#include "varbo_test.hpp"
#include "../testing/fake_predictions.hpp"

using namespace varbo;
using namespace varbo::acq;
using varbo::acq::testing::FakeSurrogate;
using varbo::acq::testing::smooth_data;
using varbo::acq::testing::smooth_prediction;

namespace {

// E[max(m − Z, 0)], Z ~ N(μ, s²), by the textbook formula (no tail care needed at the moderate u used here).
double plain_ei(double m, double mu, double s) {
  const double u = (m - mu) / s;
  return (m - mu) * normal_cdf(u) + s * normal_pdf(u);
}

}  // namespace

TEST_CASE("aei: incumbent minimizes mu + c s over the data; value = latent EI times Huang's noise factor") {
  for (bool hetero : {false, true}) {
    FakeSurrogate model([hetero](const Vec& x, bool g) { return smooth_prediction(x, g, hetero); });
    const Dataset data = smooth_data();
    for (double c : {0.0, 1.0, 3.0}) {
      // The incumbent by brute force, written independently of the class.
      double best = INFINITY, mu_best = 0;
      for (Index i = 0; i < data.size(); ++i) {
        const Prediction p = smooth_prediction(data.X.row(i).transpose(), false, hetero);
        if (p.mean + c * std::sqrt(p.latent_var) < best) {
          best = p.mean + c * std::sqrt(p.latent_var);
          mu_best = p.mean;
        }
      }
      for (bool factor : {false, true}) {
        AugmentedExpectedImprovement aei(c, factor);
        aei.prepare({&model, &data, 0, nullptr});
        for (const Vec& x : {Vec{{0.1, 0.2}}, Vec{{0.7, 0.35}}, Vec{{0.93, 0.88}}}) {
          const Prediction p = smooth_prediction(x, false, hetero);
          const double s = std::sqrt(p.latent_var);
          const double noise_sd = std::exp(0.5 * (p.log_noise_mean + 0.5 * p.log_noise_var));
          const double expected = plain_ei(mu_best, p.mean, s) *
                                  (factor ? 1 - noise_sd / std::sqrt(s * s + noise_sd * noise_sd) : 1.0);
          CHECK(aei.evaluate(x, nullptr) == doctest::Approx(expected).epsilon(1e-12));
        }
      }
    }
  }
}

TEST_CASE("aei: the incumbent's rule uses the latent sd, not the variance (two points that tell them apart)") {
  // (μ = 0, s = 0.5) and (μ = 0.3, s = 0) with c = 1: μ + c·s = 0.5 vs 0.3, the second is x**; with the variance
  // (0.25 vs 0.3) the first would be (mutation testing, session 31: the smooth test data could not tell).
  FakeSurrogate model([](const Vec& x, bool) {
    Prediction p;
    p.mean = x(0) < 0.5 ? 0.0 : 0.3;
    p.latent_var = x(0) < 0.5 ? 0.25 : 0.0;
    p.log_noise_mean = std::log(1e-4);
    return p;
  });
  Dataset data = Dataset::empty(1);
  data.add(Vec::Constant(1, 0.2), 0.0);
  data.add(Vec::Constant(1, 0.8), 0.3);
  AugmentedExpectedImprovement aei(1.0, false);
  aei.prepare({&model, &data, 0, nullptr});
  // At a candidate with μ = 0 and s = 0.5 the value is the latent EI against μ(x**) = 0.3.
  const Prediction at = model.predict(Vec::Constant(1, 0.2), false);
  CHECK(aei.evaluate(Vec::Constant(1, 0.2), nullptr) == doctest::Approx(plain_ei(0.3, at.mean, 0.5)).epsilon(1e-12));
}

TEST_CASE("aei prefers the quieter of two candidates with the same latent prediction; Kuindersma's EI does not") {
  // Two candidates, equal latent mean and variance, noise sd 0.01 at x0 < 0.5 and 1 at x0 >= 0.5.
  FakeSurrogate model([](const Vec& x, bool) {
    Prediction p;
    p.mean = 0.0;
    p.latent_var = 0.04;
    p.log_noise_mean = x[0] < 0.5 ? 2 * std::log(0.01) : 0.0;
    return p;
  });
  Dataset data = Dataset::empty(2);
  data.add(Vec{{0.5, 0.5}}, 0.1);
  AugmentedExpectedImprovement aei(1.0, true);
  aei.prepare({&model, &data, 0, nullptr});
  const double quiet = aei.evaluate(Vec{{0.2, 0.2}}, nullptr), loud = aei.evaluate(Vec{{0.8, 0.8}}, nullptr);
  CHECK(quiet > 2 * loud);
  // The noisy-y EI, E[max(μ_best − y, 0)] with y ~ N(μ, s² + σ_ε²), is larger where the noise is larger.
  CHECK(plain_ei(0.2, 0.0, std::sqrt(0.04 + 1.0)) > plain_ei(0.2, 0.0, std::sqrt(0.04 + 1e-4)));
}

TEST_CASE("aei: analytic gradient against central finite differences") {
  // Tolerance 1e-6 relative per component (floor 1e-8), step 1e-6.
  for (bool hetero : {false, true})
    for (bool factor : {false, true}) {
      FakeSurrogate model([hetero](const Vec& x, bool g) { return smooth_prediction(x, g, hetero); });
      const Dataset data = smooth_data();
      AugmentedExpectedImprovement aei(1.0, factor);
      aei.prepare({&model, &data, 0, nullptr});
      const AcquisitionFunction f(aei, 2);
      for (const Vec& x : {Vec{{0.1, 0.2}}, Vec{{0.45, 0.6}}, Vec{{0.7, 0.35}}, Vec{{0.93, 0.88}}}) {
        const GradientCheck gc = check_gradient(f, x, 1e-6, 1e-8);
        CHECK_MESSAGE(gc.max_rel_error < 1e-6, (hetero ? "hetero" : "homo") << (factor ? " factor" : "") << " at "
                                                                            << x.transpose() << ": analytic "
                                                                            << gc.analytic.transpose() << " numeric "
                                                                            << gc.numeric.transpose());
      }
    }
  // A GP leaves the log-noise gradients empty.
  FakeSurrogate gp([](const Vec& x, bool g) {
    Prediction p = smooth_prediction(x, g, false);
    p.log_noise_mean = std::log(0.01);
    p.d_log_noise_mean.resize(0);
    p.d_log_noise_var.resize(0);
    return p;
  });
  const Dataset data = smooth_data();
  AugmentedExpectedImprovement aei(1.0, true);
  aei.prepare({&gp, &data, 0, nullptr});
  CHECK(check_gradient(AcquisitionFunction(aei, 2), Vec{{0.4, 0.7}}, 1e-6, 1e-8).max_rel_error < 1e-6);
}

TEST_CASE("the plugin registers aei with validated options") {
  Registry& reg = test::registry();
  BuildContext ctx;
  ctx.dim = 2;
  FakeSurrogate model([](const Vec& x, bool g) { return smooth_prediction(x, g, true); });
  const Dataset data = smooth_data();
  for (const char* yaml : {"{type: aei}", "{type: aei, c: 0, noise_factor: false}"}) {
    auto acq = reg.create<Acquisition>(yaml, ctx);
    acq->prepare({&model, &data, 0, nullptr});
    Vec grad;
    CHECK(std::isfinite(acq->evaluate(Vec{{0.3, 0.3}}, &grad)));
    CHECK(grad.size() == 2);
    CHECK_FALSE(acq->state().empty());
  }
  CHECK_THROWS_AS(reg.create<Acquisition>("{type: aei, c: -1}", ctx), ConfigError);
  CHECK_THROWS_AS(reg.create<Acquisition>("{type: aei, kappa: 1}", ctx), ConfigError);
}

TEST_CASE("aei: overflowed noise scores 0, a NaN prediction NaN (before: the noise-free maximum)") {
  // Noise sd 1 at the evaluated point, log-noise mean at x: 710 overflows exp (n = +inf), NaN is no prediction.
  double log_noise = 0;
  double latent = 0.04;
  FakeSurrogate model([&](const Vec& x, bool) {
    Prediction p;
    p.mean = x[0] < 0.5 ? 0.0 : -0.1;
    p.latent_var = x[0] < 0.5 ? 0.04 : latent;
    p.log_noise_mean = x[0] < 0.5 ? 0.0 : log_noise;
    return p;
  });
  Dataset data = Dataset::empty(2);
  data.add(Vec{{0.2, 0.2}}, 0.0);
  AugmentedExpectedImprovement aei(1.0, true);
  aei.prepare({&model, &data, 0, nullptr});
  const Vec x{{0.8, 0.8}};
  log_noise = 700;
  CHECK(aei.evaluate(x, nullptr) == doctest::Approx(0.0).scale(1e-12));
  log_noise = 710;  // exp overflows
  CHECK(aei.evaluate(x, nullptr) == 0.0);
  log_noise = std::numeric_limits<double>::quiet_NaN();
  CHECK(std::isnan(aei.evaluate(x, nullptr)));
  log_noise = -2;
  latent = std::numeric_limits<double>::quiet_NaN();
  Vec grad;
  CHECK(std::isnan(aei.evaluate(x, &grad)));
  CHECK(grad.size() == 2);
}
