// GP fit (restarts in parallel, default settings, 1 and 2 threads) and predict at N ∈ {50, 200, 1000}, d ∈ {2, 6}, and one
// acquisition optimization (EI on the fitted GP, `multistart` with its defaults: 2000 scrambled Sobol candidates,
// the 10 best polished with L-BFGS in the box), with 1 and 2 threads.
// Data: a smooth test function on uniform points (Styblinski–Tang-like sum of sines, scaled to [0,1]^d).
#include <benchmark/benchmark.h>

#include <atomic>
#include <cmath>
#include <memory>

#include "ceres_lbfgs.hpp"
#include "gp_surrogate.hpp"
#include "varbo/acquisition.hpp"
#include "varbo/loader.hpp"
#include "varbo/parallel.hpp"
#include "varbo/region.hpp"

using namespace varbo;

namespace {

Dataset make_data(Index n, Index d, std::uint64_t seed) {
  Rng rng(seed);
  Dataset data{Mat(n, d), Vec(n)};
  for (Index i = 0; i < n; ++i) {
    data.X.row(i) = rng.uniform_vec(d).transpose();
    double y = 0;
    for (Index j = 0; j < d; ++j) y += std::sin(6.0 * data.X(i, j) + j) + 0.5 * data.X(i, j) * data.X(i, j);
    data.y(i) = y + 0.01 * rng.normal();
  }
  return data;
}

/// Counts objective evaluations and iterations of the wrapped optimizer (reported as benchmark counters).
class CountingOptimizer final : public Optimizer {
 public:
  explicit CountingOptimizer(ceres_lbfgs::LbfgsSettings s) : inner_(s) {}
  OptimizeResult maximize(const DifferentiableFunction& f, const RegionConstraint& region, const Mat& starts,
                          Rng& rng) const override {
    OptimizeResult r = inner_.maximize(f, region, starts, rng);
    evaluations += r.evaluations;
    iterations += r.iterations;
    return r;
  }
  mutable std::atomic<long> evaluations{0}, iterations{0};

 private:
  ceres_lbfgs::CeresLbfgs inner_;
};

std::shared_ptr<CountingOptimizer> make_optimizer() {
  ceres_lbfgs::LbfgsSettings lbfgs;
  lbfgs.max_iterations = 100;  // the gp component's default fit_optimizer
  return std::make_shared<CountingOptimizer>(lbfgs);
}

std::unique_ptr<gp::GpSurrogate> make_gp(std::shared_ptr<CountingOptimizer> opt = make_optimizer(),
                                         bool all_restarts = false) {
  gp::GpSettings settings;
  if (all_restarts) settings.full_fit_growth = 1.0;  // every fit runs all 4 restarts
  return std::make_unique<gp::GpSurrogate>(0, settings, std::move(opt));
}

/// A fit as inside a BO loop: warm-started from the previous fit on the data minus its last point. `restarts`
/// 0: the default (`full_fit_growth` 1.25, so on N − 1 → N points only the warm start runs); 1: all 4 restarts
/// (what a fit costs whenever N has grown by 25 %, and what every fit cost before issue 13), run in parallel.
void BM_GpFit(benchmark::State& state) {
  const Index n = state.range(0), d = state.range(1);
  ThreadLimit limit(static_cast<int>(state.range(3)));
  const Dataset data = make_data(n, d, 1);
  Dataset previous{data.X.topRows(n - 1), data.y.head(n - 1)};
  auto opt = make_optimizer();
  auto gp = make_gp(opt, state.range(2) != 0);
  Rng rng(2);
  gp->fit(previous, rng);
  const Hyperparameters warm = gp->hyperparameters();
  opt->evaluations = 0;
  opt->iterations = 0;
  for (auto _ : state) {
    state.PauseTiming();
    gp->set_hyperparameters(warm);
    state.ResumeTiming();
    const FitReport rep = gp->fit(data, rng);
    benchmark::DoNotOptimize(rep.objective);
  }
  const double fits = static_cast<double>(state.iterations());
  state.counters["evals/fit"] = static_cast<double>(opt->evaluations.load()) / fits;
  state.counters["iters/fit"] = static_cast<double>(opt->iterations.load()) / fits;
}

/// One evaluation of the fit objective with its gradient (the O(N³) unit of work).
void BM_LogPosterior(benchmark::State& state) {
  const Index n = state.range(0), d = state.range(1);
  const Dataset data = make_data(n, d, 6);
  const Vec r = (data.y.array() - data.y.mean()) / std::sqrt((data.y.array() - data.y.mean()).square().mean());
  gp::GpSurrogate gp(d, gp::GpSettings{}, make_optimizer());
  const gp::LogPosterior f(gp.kernel(), data.X, r, gp.settings().priors, gp.log_box(d));
  Vec p = Vec::Constant(d + 2, std::log(0.5));
  p(d) = 0.0;
  p(d + 1) = std::log(0.01);
  Vec g;
  for (auto _ : state) benchmark::DoNotOptimize(f.value(p, &g));
}

void BM_GpPredict(benchmark::State& state) {
  const Index n = state.range(0), d = state.range(1);
  const bool gradient = state.range(2) != 0;
  const Dataset data = make_data(n, d, 3);
  auto gp = make_gp();
  Rng rng(4);
  gp->fit(data, rng);
  Rng pts(5);
  const Vec x = pts.uniform_vec(d);
  for (auto _ : state) {
    const Prediction p = gp->predict(x, gradient);
    benchmark::DoNotOptimize(p.mean);
  }
}

/// One acquisition optimization as inside a BO iteration: EI prepared on a fitted GP, maximized by `multistart`
/// over the unit box, with the data points as extra starts (the bo algorithm adds jittered copies too).
void BM_AcquisitionOptimize(benchmark::State& state) {
  const Index n = state.range(0), d = state.range(1);
  ThreadLimit limit(static_cast<int>(state.range(2)));
  const Dataset data = make_data(n, d, 7);
  auto gp = make_gp();
  Rng rng(8);
  gp->fit(data, rng);
  BuildContext ctx;
  ctx.registry = &default_registry();
  ctx.dim = d;
  const auto ei = default_registry().create<Acquisition>("{type: ei}", ctx);
  const auto box = default_registry().create<RegionConstraint>("{type: box}", ctx);
  const auto optimizer = default_registry().create<Optimizer>("{type: multistart}", ctx);
  AcquisitionContext actx;
  actx.model = gp.get();
  actx.data = &data;
  ei->prepare(actx);
  const AcquisitionFunction f(*ei, d);
  std::uint64_t seed = 1;
  double value = 0;
  for (auto _ : state) {
    Rng orng(seed++);
    const OptimizeResult r = optimizer->maximize(f, *box, data.X, orng);
    value = r.value;
    benchmark::DoNotOptimize(value);
  }
}

}  // namespace

BENCHMARK(BM_AcquisitionOptimize)
    ->ArgsProduct({{50, 200}, {2, 6}, {1, 2}})
    ->ArgNames({"N", "d", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_GpFit)
    ->ArgsProduct({{50, 100, 200, 1000}, {2, 6}, {0, 1}, {1, 2}})
    ->ArgNames({"N", "d", "restarts", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(0.5);
BENCHMARK(BM_LogPosterior)
    ->ArgsProduct({{50, 100, 200, 1000}, {2, 6}})
    ->ArgNames({"N", "d"})
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_GpPredict)
    ->ArgsProduct({{50, 200, 1000}, {2, 6}, {0, 1}})
    ->ArgNames({"N", "d", "grad"})
    ->Unit(benchmark::kMicrosecond);

BENCHMARK_MAIN();
