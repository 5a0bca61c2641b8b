// The embedded cold path on PostgreSQL paired with the warm one on the same trial (docs/studies.md, "Where a
// PostgreSQL open + ask spends its time"). bench_suggest compares the cold path with *neighbouring* warm
// iterations, whose cost differs from trial to trial (full and warm-start refits, designs after a region restart);
// bench_open --paired removes that on SQLite by copying the file, which a PostgreSQL study cannot be. Here two
// studies hold the same trials (bench/store/pg_copy_study.sql copies one inside its database): each round asks A's
// live Study (warm: one iteration) and a fresh Study::open(B) + ask (cold, on the connection the process kept
// from the previous round, as a program reopening its study per trial has), checks that both suggest the same
// trial, then tells both its Hartmann-6 cost, and A's tell is timed too. Printed: medians (ms) of the warm ask,
// the open, the open + ask (wall and CPU, this process), their ratios, the warm tell, and how many rounds differed.
//
//   psql URL -v src=g100 -v dst=pa -f bench/store/pg_copy_study.sql     (and dst=pb)
//   nice -n 15 build/bin/bench_paired_pg 'postgresql://…&study=pa' 'postgresql://…&study=pb' [--repeats 20]
#include <malloc.h>

#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "process_stats.hpp"
#include "varbo/study_api.hpp"

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

using varbo::bench::cpu_seconds;
using varbo::bench::median;

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: bench_paired_pg URL_A URL_B [--repeats 20]   (A and B: copies of one study)\n");
    return 2;
  }
  // The allocator settings of the `varbo` executable, bench_suggest and bench_open.
  mallopt(M_MMAP_THRESHOLD, 256 << 20);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  const std::string a = argv[1], b = argv[2];
  int repeats = 20;
  for (int i = 3; i + 1 < argc; i += 2)
    if (std::string(argv[i]) == "--repeats") repeats = std::max(1, std::stoi(argv[i + 1]));
  varbo::Study live = varbo::Study::open(a);
  { varbo::Study first = varbo::Study::open(b); }  // plugins loaded and B's connection kept: not timed
  std::vector<double> warm, warm_cpu, open, cold, cold_cpu, tell;
  int differ = 0;
  for (int r = 0; r < repeats; ++r) {
    auto t0 = std::chrono::steady_clock::now();
    double c0 = cpu_seconds();
    const varbo::TrialRecord t = live.ask(1).at(0);
    warm.push_back(seconds_since(t0));
    warm_cpu.push_back(cpu_seconds() - c0);
    t0 = std::chrono::steady_clock::now();
    c0 = cpu_seconds();
    varbo::Study fresh = varbo::Study::open(b);
    open.push_back(seconds_since(t0));
    const varbo::TrialRecord u = fresh.ask(1).at(0);
    cold.push_back(seconds_since(t0));
    cold_cpu.push_back(cpu_seconds() - c0);
    if (u.id != t.id || u.x.size() != t.x.size() || (u.x - t.x).cwiseAbs().maxCoeff() > 0) ++differ;
    varbo::Rng noise = varbo::Rng(1).stream(static_cast<std::uint64_t>(t.id));
    const double cost = live.task().evaluate(t.theta, noise).cost;
    t0 = std::chrono::steady_clock::now();
    live.tell(t.id, cost);
    tell.push_back(seconds_since(t0));
    fresh.tell(u.id, cost);
  }
  const double w = median(warm), wc = median(warm_cpu), c = median(cold), cc = median(cold_cpu);
  std::printf("rounds %d, differed %d | warm ask %.2f ms (CPU %.2f) | open %.2f ms, open + ask %.2f ms (CPU %.2f) | "
              "ratio wall %.2f×, CPU %.2f× | warm tell %.2f ms\n",
              repeats, differ, 1e3 * w, 1e3 * wc, 1e3 * median(open), 1e3 * c, 1e3 * cc, c / w, cc / wc,
              1e3 * median(tell));
  return differ == 0 ? 0 : 1;
}
