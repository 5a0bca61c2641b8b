#include <cmath>

#include "confidence_region.hpp"
#include "fake_gp.hpp"
#include "hit_and_run.hpp"
#include "sample_polish.hpp"
#include "varbo/parallel.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {
// −‖x − t‖², maximized at t.
FunctionRef neg_distance(const Vec& t, bool gradient = true) {
  return FunctionRef(
      t.size(),
      [t](const Vec& x, Vec* g) {
        if (g) *g = -2.0 * (x - t);
        return -(x - t).squaredNorm();
      },
      gradient);
}

std::unique_ptr<SamplePolishOptimizer> make_optimizer(Index samples = 300) {
  HitAndRunOptions h;
  h.chains = 32;
  SamplePolishOptions s;
  s.samples = samples;
  return std::make_unique<SamplePolishOptimizer>(std::make_unique<HitAndRunSampler>(h), s);
}

struct CrboSetup {
  test::FakeSEGP gp{1.0, 0.15, 1e-4};
  Dataset data = Dataset::empty(2);
  ConfidenceRegion region{2, {}};
  CrboSetup() {
    data.add((Vec(2) << 0.3, 0.3).finished(), 0.5);
    data.add((Vec(2) << 0.4, 0.35).finished(), 0.1);
    gp.condition(data);
    Rng rng(1);
    region.update(&gp, data, rng);
  }
};
}  // namespace

TEST_CASE("sample_polish: unconstrained box, the polish reaches the interior maximum") {
  BoxRegion box(Box::unit(3));
  const Vec t = (Vec(3) << 0.2, 0.7, 0.55).finished();
  const auto f = neg_distance(t);
  Rng rng(5);
  const OptimizeResult r = make_optimizer()->maximize(f, box, Mat(0, 3), rng);
  CHECK(r.success);
  // SLSQP on a quadratic from a start within 0.1 per coordinate: converges to machine-level accuracy;
  // 1e-6 leaves room for the 1e-4 relative stopping tolerance.
  CHECK((r.x - t).norm() < 1e-6);
}

TEST_CASE("sample_polish: the result is inside the confidence region and on its boundary") {
  CrboSetup s;
  const Vec t = (Vec(2) << 0.9, 0.9).finished();  // far outside C_n: the constrained maximum is on ∂C_n
  const auto f = neg_distance(t);
  Rng rng(5);
  const OptimizeResult r = make_optimizer()->maximize(f, s.region, Mat(0, 2), rng);
  REQUIRE(r.success);
  CHECK(s.region.contains(r.x));
  // Reference: a dense grid of C_n (step 0.002) — the optimizer must match or beat the best grid point.
  double best_grid = -1e300;
  for (int i = 0; i <= 500; ++i)
    for (int j = 0; j <= 500; ++j) {
      const Vec x = (Vec(2) << i / 500.0, j / 500.0).finished();
      if (s.region.contains(x)) best_grid = std::max(best_grid, f.value(x, nullptr));
    }
  MESSAGE("sample_polish value " << r.value << ", best feasible grid point " << best_grid);
  CHECK(r.value >= best_grid - 1e-6);
  CHECK(s.region.constraint(r.x, nullptr) < 1e-3);  // active constraint
}

TEST_CASE("sample_polish: a sampler's points outside the region's constraint are not candidates") {
  // A sampler that ignores the constraint (around_initial_point does; a third party's may): its points far outside
  // C_n, nearest the maximizer, were candidates, and the polish did not always bring the best back inside (3 of 9
  // CRBO suggestions left the region; red team, session 26). Here every sampler point but one lies outside.
  struct Outside final : Sampler {
    Mat sample(const RegionConstraint&, Index n, Rng&) const override {
      Mat m(n, 2);
      for (Index i = 0; i < n; ++i) m.row(i) << 0.85 + 0.1 * double(i) / double(n), 0.9;
      m.row(0) << 0.35, 0.32;  // inside C_n
      return m;
    }
  };
  CrboSetup s;
  REQUIRE(!s.region.contains((Vec(2) << 0.9, 0.9).finished()));
  const auto f = neg_distance((Vec(2) << 0.9, 0.9).finished(), false);  // COBYLA: no gradient to steer back
  SamplePolishOptions o;
  o.samples = 50;
  o.polish = 3;
  const SamplePolishOptimizer opt(std::make_unique<Outside>(), o);
  Rng rng(5);
  const OptimizeResult r = opt.maximize(f, s.region, Mat(0, 2), rng);
  REQUIRE(r.x.size() == 2);
  CHECK(s.region.contains(r.x, 1e-9));
}

TEST_CASE("sample_polish: derivative-free fallback (COBYLA) stays feasible and improves on the samples") {
  CrboSetup s;
  const auto f = neg_distance((Vec(2) << 0.9, 0.9).finished(), false);
  Rng rng(8);
  const OptimizeResult r = make_optimizer()->maximize(f, s.region, Mat(0, 2), rng);
  REQUIRE(r.success);
  CHECK(s.region.contains(r.x));
  SamplePolishOptions no_polish;
  no_polish.samples = 300;
  no_polish.polish = 0;
  HitAndRunOptions h;
  h.chains = 32;
  SamplePolishOptimizer sampling_only(std::make_unique<HitAndRunSampler>(h), no_polish);
  Rng rng2(8);
  const OptimizeResult r0 = sampling_only.maximize(f, s.region, Mat(0, 2), rng2);
  CHECK(r.value >= r0.value);
}

TEST_CASE("sample_polish: NaN values are survived, and same seed gives the same result on 1 and 2 threads") {
  CrboSetup s;
  FunctionRef nan_half(2, [](const Vec& x, Vec* g) {
    if (g) *g = Vec::Zero(2);
    return x[0] > 0.35 ? std::nan("") : x[0];
  });
  Rng rng(3);
  const OptimizeResult r = make_optimizer()->maximize(nan_half, s.region, Mat(0, 2), rng);
  CHECK(r.success);
  CHECK(std::isfinite(r.value));
  CHECK(s.region.contains(r.x));

  const auto f = neg_distance((Vec(2) << 0.9, 0.1).finished());
  OptimizeResult a, b;
  {
    ThreadLimit one(1);
    Rng rr(42);
    a = make_optimizer()->maximize(f, s.region, Mat(0, 2), rr);
  }
  {
    ThreadLimit two(2);
    Rng rr(42);
    b = make_optimizer()->maximize(f, s.region, Mat(0, 2), rr);
  }
  CHECK((a.x - b.x).norm() == 0.0);
  CHECK(a.value == b.value);
}

TEST_CASE("sample_polish: registered with its sampler option and the optimizer:constraints tag") {
  const auto& info = test::registry().find(Kind::Optimizer, "sample_polish");
  CHECK(info.provides == std::vector<std::string>{"optimizer:constraints"});
  BuildContext ctx;
  ctx.dim = 2;
  auto opt = test::registry().create<Optimizer>(
      "{type: sample_polish, samples: 100, sampler: {type: hit_and_run, chains: 8}}", ctx);
  CrboSetup s;
  Rng rng(1);
  const OptimizeResult r = opt->maximize(neg_distance((Vec(2) << 0.9, 0.9).finished()), s.region, Mat(0, 2), rng);
  CHECK(r.success);
  CHECK(s.region.contains(r.x));
}
