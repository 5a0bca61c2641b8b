// Statistics of each noise model on n = 200 000 draws against closed forms. Tolerances: a sample mean within
// 6 standard errors (SE from the closed-form variance); a Gaussian sample variance within 6 SE (SE = σ²√(2/n));
// a fraction within 6 binomial SE. With fixed seeds the tests are deterministic; the bounds say how far from
// the closed form an honest sampler may be.
#include <cmath>
#include <numbers>

#include "noise_models.hpp"
#include "varbo_test.hpp"

using namespace varbo;
using namespace varbo::tasks::noisy;

namespace {
constexpr int n = 200000;

struct Moments {
  double mean = 0, var = 0;
};
Moments moments(const std::vector<double>& v) {
  Moments m;
  for (double x : v) m.mean += x;
  m.mean /= static_cast<double>(v.size());
  for (double x : v) m.var += (x - m.mean) * (x - m.mean);
  m.var /= static_cast<double>(v.size() - 1);
  return m;
}
std::vector<double> draws(const Noise& noise, double g, const Vec& u, std::uint64_t seed) {
  Rng rng(seed);
  std::vector<double> v(n);
  for (auto& x : v) x = noise.apply(g, u, rng);
  return v;
}
void check_mean(double sample, double mean, double var) {
  CHECK(std::abs(sample - mean) <= 6 * std::sqrt(var / n));
}
void check_gaussian_var(double sample, double var) { CHECK(std::abs(sample - var) <= 6 * var * std::sqrt(2.0 / n)); }
// (e^c - 1)/c = E[e^{cU}], U ~ U[0, 1), with its limit 1 at c = 0.
double mgf_uniform(double c) { return std::abs(c) < 1e-12 ? 1.0 : std::expm1(c) / c; }
}  // namespace

TEST_CASE("levels: BBOB's noisy-suite constants") {
  const auto M = NoiseLevel::Moderate, S = NoiseLevel::Severe;
  CHECK(Noise::make(NoiseModel::Multiplicative, M, 2).beta == 0.01);
  CHECK(Noise::make(NoiseModel::Multiplicative, S, 2).beta == 1.0);
  CHECK(Noise::make(NoiseModel::UniformMultiplicative, M, 2).alpha == doctest::Approx(0.01 * 0.99));
  CHECK(Noise::make(NoiseModel::UniformMultiplicative, S, 5).alpha == doctest::Approx(0.69));
  CHECK(Noise::make(NoiseModel::Cauchy, M, 2).p == 0.05);
  CHECK(Noise::make(NoiseModel::Cauchy, S, 2).p == 0.2);
  CHECK(Noise::make(NoiseModel::Additive, S, 2).sigma == 1.0);
  for (const auto& name : noise_model_names()) CHECK(noise_model_name(noise_model_from_name(name)) == name);
  CHECK_THROWS_AS(noise_model_from_name("gaussian"), std::invalid_argument);
  CHECK_THROWS_AS(noise_level_from_name("mild"), std::invalid_argument);
  CHECK(heteroscedastic(NoiseModel::Cauchy));
  CHECK(!heteroscedastic(NoiseModel::Additive));
}

TEST_CASE("none: the value itself, and the stream untouched") {
  const Noise none = Noise::make(NoiseModel::None, NoiseLevel::Severe, 2);
  Rng a(4), b(4);
  CHECK(none.apply(3.5, Vec::Zero(2), a) == 3.5);
  CHECK(a.next() == b.next());
}

TEST_CASE("additive: mean g, variance σ²") {
  for (auto level : {NoiseLevel::Moderate, NoiseLevel::Severe}) {
    const Noise nz = Noise::make(NoiseModel::Additive, level, 3);
    const auto m = moments(draws(nz, 2.0, Vec::Constant(3, 0.3), 1));
    check_mean(m.mean, 2.0, nz.sigma * nz.sigma);
    check_gaussian_var(m.var, nz.sigma * nz.sigma);
  }
}

TEST_CASE("multiplicative: g exp(βN) is log-normal") {
  for (auto level : {NoiseLevel::Moderate, NoiseLevel::Severe}) {
    const Noise nz = Noise::make(NoiseModel::Multiplicative, level, 2);
    const double g = 2.0, b2 = nz.beta * nz.beta;
    const auto v = draws(nz, g, Vec::Zero(2), 2);
    const auto m = moments(v);
    // E = g e^{β²/2}, Var = g² e^{β²}(e^{β²} - 1).
    check_mean(m.mean, g * std::exp(b2 / 2), g * g * std::exp(b2) * std::expm1(b2));
    std::vector<double> logs;
    for (double x : v) logs.push_back(std::log(x / g));
    const auto ml = moments(logs);  // log(g̃/g) = βN exactly
    check_mean(ml.mean, 0.0, b2);
    check_gaussian_var(ml.var, b2);
  }
  Rng rng(1);  // g = 0 stays 0: the optimum is observed without noise, as in BBOB
  CHECK(Noise::make(NoiseModel::Multiplicative, NoiseLevel::Severe, 2).apply(0.0, Vec::Zero(2), rng) == 0.0);
}

TEST_CASE("uniform multiplicative: closed-form moments of g U1^β K^{αU2}, K = 1e9/g") {
  for (auto level : {NoiseLevel::Moderate, NoiseLevel::Severe}) {
    for (Index d : {2, 5}) {
      for (double g : {1.0, 1e3, 2e9}) {
        CAPTURE(d);
        CAPTURE(g);
        const Noise nz = Noise::make(NoiseModel::UniformMultiplicative, level, d);
        const double b = nz.beta;
        const double c = g < 1e9 ? nz.alpha * std::log(1e9 / g) : 0.0;  // max(1, K^{αU}) = K^{αU} iff K ≥ 1
        const auto v = draws(nz, g, Vec::Zero(d), 3);
        const auto m = moments(v);
        const double mean = g / (1 + b) * mgf_uniform(c);
        const double second = g * g / (1 + 2 * b) * mgf_uniform(2 * c);
        check_mean(m.mean, mean, second - mean * mean);
        // log g̃ = log g + β log U1 + c U2: mean log g - β + c/2, variance β² + c²/12.
        std::vector<double> logs;
        for (double x : v) logs.push_back(std::log(x));
        const auto ml = moments(logs);
        const double var_log = b * b + c * c / 12;
        check_mean(ml.mean, std::log(g) - b + c / 2, var_log);
        CHECK(ml.var == doctest::Approx(var_log).epsilon(0.03));  // 3 %: > 6 SE for these (bounded) laws
      }
    }
  }
}

TEST_CASE("cauchy: a fraction p of evaluations hit by α·Cauchy, clipped below at -1000α") {
  for (auto level : {NoiseLevel::Moderate, NoiseLevel::Severe}) {
    const Noise nz = Noise::make(NoiseModel::Cauchy, level, 2);
    const double g = 5.0;
    const auto v = draws(nz, g, Vec::Zero(2), 4);
    int hit = 0, big = 0, positive = 0;
    double lowest = INFINITY;
    for (double x : v) {
      lowest = std::min(lowest, x);
      if (x == g) continue;
      ++hit;
      const double c = (x - g) / nz.alpha;
      big += std::abs(c) > 1;  // P(|C| > 1) = 1/2 for a standard Cauchy
      positive += c > 0;       // symmetric
    }
    const double p = nz.p;
    CHECK(std::abs(hit / double(n) - p) <= 6 * std::sqrt(p * (1 - p) / n));
    const double se_half = 6 * std::sqrt(0.25 / hit);
    CHECK(std::abs(big / double(hit) - 0.5) <= se_half);
    CHECK(std::abs(positive / double(hit) - 0.5) <= se_half);
    CHECK(lowest >= g - 1000 * nz.alpha);
    // Outliers are heavy-tailed: some beyond 100α (P = 2/π·atan(1/100)·p ≈ 0.64 % of hits) appear in 2e5 draws.
    CHECK(*std::max_element(v.begin(), v.end()) > g + 100 * nz.alpha);
  }
}

TEST_CASE("input-dependent: Gaussian with σ(u) = σ(0.02 + 1.98 mean(u))") {
  for (auto level : {NoiseLevel::Moderate, NoiseLevel::Severe}) {
    const Noise nz = Noise::make(NoiseModel::InputDependent, level, 2);
    Vec lo = Vec::Zero(2), mid(2), hi = Vec::Ones(2);
    mid << 0.2, 0.8;
    int seed = 10;
    for (const auto& [u, factor] : std::vector<std::pair<Vec, double>>{{lo, 0.02}, {mid, 1.01}, {hi, 2.0}}) {
      const double s = nz.sigma * factor;
      CHECK(nz.input_sigma(u) == doctest::Approx(s).epsilon(1e-14));
      const auto m = moments(draws(nz, 1.0, u, static_cast<std::uint64_t>(seed++)));
      check_mean(m.mean, 1.0, s * s);
      check_gaussian_var(m.var, s * s);
    }
  }
}

TEST_CASE("every model gives a finite cost, even for huge g") {
  Rng rng(8);
  for (const auto& name : noise_model_names())
    for (auto level : {NoiseLevel::Moderate, NoiseLevel::Severe}) {
      const Noise nz = Noise::make(noise_model_from_name(name), level, 2);
      for (double g : {0.0, 1e-300, 1.0, 1e11, 1e300}) {
        for (int i = 0; i < 200; ++i) {
          const double x = nz.apply(g, Vec::Constant(2, 0.5), rng);
          CHECK(std::isfinite(x));
          CHECK(std::abs(x) <= std::max(kNoiseClip, g));
        }
      }
    }
}
