// Hit-and-run throughput (Fröhlich 2021, Alg. 1): samples per second of the `hit_and_run` sampler
//  * in a ball (a cheap constraint: the cost of the chain moves, bracketing and shrinking themselves), and
//  * in CRBO's confidence region σ_n(θ) ≤ γσ_f of a GP (every membership test is a GP prediction), at the
//    sizes CRBO runs at: d = 10, N = 50 and d = 100, N = 200,
// with 1 and 2 threads. One iteration draws 1000 samples (sample_polish's default in the CRBO examples).
//
//   build/bin/bench_hit_and_run --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <cmath>
#include <map>
#include <memory>
#include <utility>

#include "varbo/loader.hpp"
#include "varbo/log.hpp"
#include "varbo/parallel.hpp"
#include "varbo/region.hpp"
#include "varbo/sampler.hpp"
#include "varbo/surrogate.hpp"

namespace {

using namespace varbo;

constexpr Index kSamples = 1000;

/// Ball of radius 0.3 around the centre of the unit cube; chains start at the centre.
class Ball final : public RegionConstraint {
 public:
  explicit Ball(Index d) : box_(Box::unit(d)), c_(Vec::Constant(d, 0.5)) {}
  const Box& bounds() const override { return box_; }
  bool has_constraint() const override { return true; }
  double constraint(const Vec& x, Vec* g) const override {
    if (g) *g = -2.0 * (x - c_);
    return 0.09 - (x - c_).squaredNorm();
  }
  Mat seeds() const override { return c_.transpose(); }

 private:
  Box box_;
  Vec c_;
};

std::unique_ptr<Sampler> make_sampler(Index d) {
  BuildContext ctx;
  ctx.registry = &default_registry();
  ctx.dim = d;
  return default_registry().create<Sampler>("{type: hit_and_run}", ctx);
}

/// A fitted GP and its confidence region (γ = 0.6) on N points clustered around θ0 = centre, as after N CRBO
/// trials: costs of a smooth function of the first coordinates plus noise.
struct ConfidenceSetup {
  std::unique_ptr<Surrogate> model;
  std::unique_ptr<RegionConstraint> region;
  Dataset data = Dataset::empty(1);

  ConfidenceSetup(Index d, Index n) : data(Dataset::empty(d)) {
    BuildContext ctx;
    ctx.registry = &default_registry();
    ctx.dim = d;
    // The model only shapes the region being sampled; its kernel is pinned so the tables (docs/crbo.md) do not
    // move with the gp's default (`kernel: auto` since session 16).
    model = default_registry().create<Surrogate>(
        "{type: gp, kernel: matern52_ard, restarts: 1, max_lengthscale: 0.5}", ctx);
    region = default_registry().create<RegionConstraint>("{type: confidence, gamma: 0.6, report: false}", ctx);
    Rng rng(11);
    for (Index i = 0; i < n; ++i) {
      Vec x = Vec::Constant(d, 0.5);
      for (Index j = 0; j < d; ++j) x(j) += 0.05 * rng.normal();
      x = x.cwiseMax(0.0).cwiseMin(1.0);
      data.add(x, std::sin(6 * x(0)) + (x.head(std::min<Index>(d, 5)).array() - 0.5).square().sum() +
                      0.01 * rng.normal());
    }
    Rng fit_rng(5);
    model->fit(data, fit_rng);
    region->update(model.get(), data, fit_rng);
  }
};

const ConfidenceSetup& confidence_setup(Index d, Index n) {
  static std::map<std::pair<Index, Index>, std::unique_ptr<ConfidenceSetup>> cache;
  auto& slot = cache[{d, n}];
  if (!slot) slot = std::make_unique<ConfidenceSetup>(d, n);
  return *slot;
}

void run(benchmark::State& state, const RegionConstraint& region, Index d, int threads) {
  ThreadLimit limit(threads);
  const auto sampler = make_sampler(d);
  std::uint64_t seed = 1;
  for (auto _ : state) {
    Rng rng(seed++);
    Mat s = sampler->sample(region, kSamples, rng);
    benchmark::DoNotOptimize(s.data());
  }
  state.SetItemsProcessed(state.iterations() * kSamples);
}

// args: d, threads
void BM_HitAndRunBall(benchmark::State& state) {
  const Index d = state.range(0);
  Ball ball(d);
  run(state, ball, d, static_cast<int>(state.range(1)));
}

// args: d, N, threads
void BM_HitAndRunConfidenceRegion(benchmark::State& state) {
  const Index d = state.range(0);
  run(state, *confidence_setup(d, state.range(1)).region, d, static_cast<int>(state.range(2)));
}

}  // namespace

BENCHMARK(BM_HitAndRunBall)->ArgsProduct({{10, 100}, {1, 2}})->ArgNames({"d", "threads"})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_HitAndRunConfidenceRegion)
    ->Args({10, 50, 1})->Args({10, 50, 2})->Args({100, 200, 1})->Args({100, 200, 2})
    ->ArgNames({"d", "N", "threads"})->Unit(benchmark::kMillisecond)->UseRealTime();

int main(int argc, char** argv) {
  varbo::set_log_level(varbo::LogLevel::Error);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
