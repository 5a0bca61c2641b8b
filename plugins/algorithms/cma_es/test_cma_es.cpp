#include <algorithm>
#include <cmath>
#include <functional>
#include <utility>
#include <vector>

#include "cma_es.hpp"
#include "varbo/errors.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {
// Runs `evaluations` ask(1)/tell steps; returns the best cost.
double run(CmaEs& es, const std::function<double(const Vec&)>& f, int evaluations) {
  double best = std::numeric_limits<double>::infinity();
  for (int k = 0; k < evaluations; ++k) {
    const auto s = es.ask(1);
    const double c = f(s[0].x);
    best = std::min(best, c);
    es.tell({Observation{s[0].x, c, true, {}}});
  }
  return best;
}
const Vec kOpt = Vec::LinSpaced(10, 0.3, 0.6);  // interior optimum
double sphere(const Vec& x) { return (x - kOpt).squaredNorm(); }
double ellipsoid(const Vec& x) {  // condition number 1e6
  double s = 0;
  for (Index i = 0; i < x.size(); ++i) s += std::pow(1e6, double(i) / double(x.size() - 1)) * std::pow(x[i] - kOpt[i], 2);
  return s;
}
}  // namespace

TEST_CASE("cma_es: default parameters of Hansen's tutorial") {
  CmaEs es(10, {});
  CHECK(es.lambda() == 10);  // 4 + floor(3 ln 10) = 4 + 6
  CmaEs es2(100, {});
  CHECK(es2.lambda() == 17);  // 4 + floor(3 ln 100) = 4 + 13
}

TEST_CASE("cma_es: minimizes a sphere and an ellipsoid in d = 10") {
  CmaEsOptions o;
  o.seed = 1;
  CmaEs es(10, o);
  const double s = run(es, sphere, 1500);
  MESSAGE("sphere d=10, 1500 evaluations: best " << s);
  CHECK(s < 1e-10);
  CmaEs es2(10, o);
  const double e = run(es2, ellipsoid, 8000);
  MESSAGE("ellipsoid d=10 (cond 1e6), 8000 evaluations: best " << e);
  CHECK(e < 1e-8);
}

TEST_CASE("cma_es: stays in the unit cube with the optimum on the boundary; failures are survived") {
  CmaEsOptions o;
  o.seed = 2;
  CmaEs es(5, o);
  const Vec corner = (Vec(5) << 0, 1, 0, 1, 0.5).finished();  // outside-leaning optimum on the boundary
  double best = 1e300;
  for (int k = 0; k < 1500; ++k) {
    const auto s = es.ask(1);
    REQUIRE(Box::unit(5).contains(s[0].x));
    const bool fail = k % 7 == 3;  // every 7th trial fails
    const double c = (s[0].x - corner).squaredNorm();
    if (!fail) best = std::min(best, c);
    es.tell({Observation{s[0].x, fail ? 0.0 : c, !fail, {}}});
  }
  MESSAGE("boundary optimum, 1500 evaluations with 1/7 failures: best " << best);
  CHECK(best < 1e-8);
  REQUIRE(es.recommendation());
  CHECK((*es.recommendation() - corner).norm() < 1e-4);
}

TEST_CASE("cma_es: deterministic per seed; batched asks give the same candidates as single asks") {
  auto f = [](const Vec& x) { return (x - Vec::Constant(4, 0.2)).squaredNorm(); };
  CmaEsOptions o;
  o.seed = 5;
  CmaEs a(4, o), b(4, o);
  run(a, f, 300);
  run(b, f, 300);
  CHECK((a.mean() - b.mean()).norm() == 0.0);
  CHECK(a.sigma() == b.sigma());
  CmaEs c(4, o), d(4, o);
  const auto all = c.ask(c.lambda());
  for (Index k = 0; k < d.lambda(); ++k) CHECK((d.ask(1)[0].x - all[static_cast<std::size_t>(k)].x).norm() == 0.0);
  // Results told in any order update the generation once all lambda have arrived.
  std::vector<Observation> obs;
  for (auto it = all.rbegin(); it != all.rend(); ++it) obs.push_back(Observation{it->x, f(it->x), true, {}});
  c.tell(obs);
  CHECK(c.generation() == 1);
}

TEST_CASE("cma_es: registered; x0 and sigma0 options; wrong x0 is a ConfigError") {
  BuildContext ctx;
  ctx.dim = 3;
  ctx.seed = 1;
  auto alg = test::registry().create<Algorithm>("{type: cma_es, sigma0: 0.1, x0: [0.2, 0.2, 0.2]}", ctx);
  const auto s = alg->ask(1);
  CHECK(s.size() == 1);
  CHECK((s[0].x - Vec::Constant(3, 0.2)).norm() < 1.0);
  CHECK_THROWS_AS(test::registry().create<Algorithm>("{type: cma_es, x0: [0.2, 0.2]}", ctx), ConfigError);
  CHECK_THROWS_AS(test::registry().create<Algorithm>("{type: cma_es, x0: [0.2, 0.2, 2.0]}", ctx), ConfigError);
}

TEST_CASE("cma_es: recommendation: mean recommends the distribution mean, clipped to the box") {
  auto f = [](const Vec& x) { return (x - Vec::Constant(3, 0.4)).squaredNorm(); };
  CmaEsOptions o;
  o.seed = 2;
  o.recommend_mean = true;
  CmaEs es(3, o);
  run(es, f, 60);
  REQUIRE(es.recommendation());
  CHECK((*es.recommendation() - Box::unit(3).clamp(es.mean())).norm() == 0.0);
}

TEST_CASE("cma_es: one generation's update equals Hansen's tutorial, recomputed here") {
  // An independent recomputation of the first update (Hansen 2016, eqs. (39)–(47) with positive weights, Table 1's
  // parameters) from the candidates and their costs; C, m, σ must agree to round-off. It catches, e.g., a rank-μ
  // term divided by μ_eff (a surviving mutant of session 31: the optimizer still converged, only slower).
  const Index n = 4;
  CmaEsOptions o;
  o.seed = 11;
  o.sigma0 = 0.05;  // from the centre: no candidate is clipped (10 σ to the faces), so z = x
  CmaEs es(n, o);
  const Index lambda = es.lambda();
  REQUIRE(lambda == 8);  // 4 + floor(3 ln 4)
  const Vec m0 = es.mean();
  const auto cost = [](const Vec& x) { return (x - Vec::LinSpaced(4, 0.2, 0.8)).squaredNorm() + 3.0 * x(0) * x(1); };
  std::vector<std::pair<double, Vec>> told;
  for (Index k = 0; k < lambda; ++k) {
    const Vec x = es.ask(1).front().x;
    REQUIRE(((x.array() > 0) && (x.array() < 1)).all());
    told.emplace_back(cost(x), x);
    es.tell({Observation{x, told.back().first, true, {}}});
  }
  REQUIRE(es.generation() == 1);
  std::sort(told.begin(), told.end(), [](const auto& a, const auto& b) { return a.first < b.first; });

  const double d = static_cast<double>(n), lam = static_cast<double>(lambda);
  const Index mu = lambda / 2;
  Vec w(mu);
  for (Index i = 0; i < mu; ++i) w(i) = std::log((lam + 1) / 2) - std::log(static_cast<double>(i + 1));
  w /= w.sum();
  const double mueff = 1 / w.squaredNorm();
  const double cc = (4 + mueff / d) / (d + 4 + 2 * mueff / d), cs = (mueff + 2) / (d + mueff + 5);
  const double c1 = 2 / ((d + 1.3) * (d + 1.3) + mueff);
  const double cmu = std::min(1 - c1, 2 * (mueff - 2 + 1 / mueff) / ((d + 2) * (d + 2) + mueff));
  const double damps = 1 + 2 * std::max(0.0, std::sqrt((mueff - 1) / (d + 1)) - 1) + cs;
  const double chin = std::sqrt(d) * (1 - 1 / (4 * d) + 1 / (21 * d * d));

  Vec yw = Vec::Zero(n);
  Mat rank_mu = Mat::Zero(n, n);
  for (Index i = 0; i < mu; ++i) {
    const Vec y = (told[static_cast<std::size_t>(i)].second - m0) / o.sigma0;
    yw += w(i) * y;
    rank_mu += w(i) * y * y.transpose();
  }
  const Vec ps = std::sqrt(cs * (2 - cs) * mueff) * yw;  // C⁻½ = I in the first generation
  const bool hsig = ps.norm() / std::sqrt(1 - (1 - cs) * (1 - cs)) < (1.4 + 2 / (d + 1)) * chin;
  const Vec pc = (hsig ? std::sqrt(cc * (2 - cc) * mueff) : 0.0) * yw;
  const Mat C = (1 - c1 - cmu + (hsig ? 0.0 : c1 * cc * (2 - cc))) * Mat::Identity(n, n) + c1 * pc * pc.transpose() +
                cmu * rank_mu;
  const double sigma = o.sigma0 * std::exp(cs / damps * (ps.norm() / chin - 1));

  CHECK((es.mean() - (m0 + o.sigma0 * yw)).norm() <= 1e-14);
  CHECK(std::abs(es.sigma() - sigma) <= 1e-14 * sigma);
  CHECK((es.covariance() - C).norm() <= 1e-13 * C.norm());
}
