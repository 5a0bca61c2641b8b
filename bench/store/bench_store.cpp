// Study store overheads (no model fitting: the random algorithm):
//  - one suggest/observe round trip (open-free, as an embedded program does; and with a fresh Study::open per
//    call, as the CLI does);
//  - resuming (opening + replaying) a 1,000-trial study.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <string>

#include "varbo/study_api.hpp"

namespace {

std::string fresh(const std::string& name) {
  const auto p = std::filesystem::temp_directory_path() / ("varbo_bench_" + name + ".db");
  for (const char* s : {"", "-wal", "-shm"}) std::filesystem::remove(p.string() + s);
  return p.string();
}

std::string yaml(long budget) {
  return "task: {type: branin}\nbudget: " + std::to_string(budget) + "\nseed: 1\nalgorithm: {type: random}\n";
}

void BM_SuggestObserveRoundTrip(benchmark::State& state) {
  // Random search samples its whole budget up front: keep it just above the iterations run.
  const std::string file = fresh("roundtrip");
  varbo::Study s = varbo::Study::create_from_yaml(file, yaml(3000));
  for (auto _ : state) {
    const auto t = s.ask(1);
    s.tell(t[0].id, t[0].theta.squaredNorm());
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_SuggestObserveRoundTrip)->Iterations(2000)->Unit(benchmark::kMicrosecond);

void BM_SuggestObserveReopen(benchmark::State& state) {
  // Each call opens the study like `varbo suggest` / `varbo observe` (plugins already loaded in-process), on a
  // study that already holds `range(0)` trials: the replay cost grows with the study.
  const std::string file = fresh("reopen");
  {
    varbo::Study s = varbo::Study::create_from_yaml(file, yaml(state.range(0) + 200));
    for (long i = 0; i < state.range(0); ++i) {
      const auto t = s.ask(1);
      s.tell(t[0].id, 1.0);
    }
  }
  for (auto _ : state) {
    std::int64_t id;
    double c;
    {
      varbo::Study s = varbo::Study::open(file);
      const auto t = s.ask(1);
      id = t[0].id;
      c = t[0].theta.squaredNorm();
    }
    varbo::Study s = varbo::Study::open(file);
    s.tell(id, c);
  }
}
BENCHMARK(BM_SuggestObserveReopen)->Arg(10)->Arg(1000)->Iterations(100)->Unit(benchmark::kMillisecond);

void BM_Resume1000(benchmark::State& state) {
  const std::string file = fresh("resume");
  {
    varbo::Study s = varbo::Study::create_from_yaml(file, yaml(2000));
    for (int i = 0; i < 1000; ++i) {
      const auto t = s.ask(1);
      s.tell(t[0].id, t[0].theta.squaredNorm());
    }
  }
  for (auto _ : state) {
    varbo::Study s = varbo::Study::open(file);
    const auto t = s.ask(1);  // forces the replay of all 1,000 trials
    benchmark::DoNotOptimize(t);
    state.PauseTiming();
    s.abandon(0);  // keep the study at 1,000 finished trials
    state.ResumeTiming();
  }
}
BENCHMARK(BM_Resume1000)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
