#include <cmath>
#include <functional>

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
