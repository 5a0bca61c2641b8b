// The embedded cold path alone (docs/studies.md, "Cost of varbo suggest"): a fresh varbo::Study::open of a stored
// study followed by ask(1), repeated on fresh copies of the study file in one process, as a program that opens
// the study per request does; for `perf record` and for before/after comparisons of that path. A first open
// (untimed) loads the plugins, as in bench_suggest, whose process keeps a study open. Printed: medians of the
// wall and CPU seconds (this process, all threads) of Study::open, of ask(1), of both, and of the fit and
// acquisition seconds the trial recorded (wall), so that "open + ask minus fit and acquisition" is what opening
// adds to one iteration.
//
//   build/bin/bench_open STUDY.db [--repeats 30]      (STUDY.db from bench/store/make_study.py; SQLite)
//   build/bin/bench_open 'postgresql://...&study=NAME' [--repeats 30]
// A PostgreSQL study is not copied: each round opens it, asks, and tells the trial its Hartmann-6 cost (untimed),
// so the study grows by one trial per round and every open finds it as a serial run left it.
//   build/bin/bench_open STUDY.db --paired 1 [--repeats 30]
// Paired (SQLite): the same trial asked warm and cold. From a fresh copy, open, ask and tell one trial (its
// Hartmann-6 cost), then either ask the next trial on that live Study (warm: one iteration) or close it, reopen and
// ask (cold: Study::open + ask); both compute the same trial (checked: same point), so their ratio is free of the
// spread between neighbouring iterations (full and warm-start refits, designs after a region restart).

#include <fmt/format.h>
#include <malloc.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "process_stats.hpp"
#include "varbo/store.hpp"
#include "varbo/study_api.hpp"

namespace {

using varbo::bench::cpu_seconds;
using varbo::bench::median;

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: bench_open STUDY.db [--repeats 30]\n");
    return 2;
  }
  // The allocator settings of the `varbo` executable and of bench_suggest.
  mallopt(M_MMAP_THRESHOLD, 256 << 20);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  namespace fs = std::filesystem;
  const std::string db = argv[1];
  int repeats = 30;
  bool paired = false;
  for (int i = 2; i + 1 < argc; i += 2) {
    if (std::string(argv[i]) == "--repeats") repeats = std::max(1, std::stoi(argv[i + 1]));
    if (std::string(argv[i]) == "--paired") paired = std::string(argv[i + 1]) != "0";
  }
  const fs::path scratch = fs::temp_directory_path() / fmt::format("varbo_bench_open_{}", ::getpid());
  fs::create_directories(scratch);
  const bool url = varbo::is_database_url(db);
  const std::string copy = url ? db : (scratch / "study.db").string();
  auto fresh_copy = [&] {
    if (url) return;
    for (const char* s : {"", "-wal", "-shm"}) fs::remove(copy + s);
    fs::copy_file(db, copy);
    if (fs::exists(db + "-wal")) fs::copy_file(db + "-wal", copy + "-wal");
  };
  varbo::Rng rng(1);
  {
    fresh_copy();
    varbo::Study first = varbo::Study::open(copy);  // the plugins are loaded: not timed
    const varbo::TrialRecord t = first.ask(1).at(0);
    if (url) first.tell(t.id, first.task().evaluate(t.theta, rng).cost);
  }
  if (paired && !url) {
    auto step = [&](varbo::Study& st) {  // ask and tell one trial, its cost a function of the trial alone
      const varbo::TrialRecord t = st.ask(1).at(0);
      varbo::Rng r = varbo::Rng(1).stream(static_cast<std::uint64_t>(t.id));
      st.tell(t.id, st.task().evaluate(t.theta, r).cost);
    };
    std::vector<double> warm_wall, warm_cpu, cold_wall, cold_cpu, fit;
    int mismatches = 0;
    for (int r = 0; r < repeats; ++r) {
      fresh_copy();
      varbo::Vec warm_x;
      {
        varbo::Study st = varbo::Study::open(copy);
        step(st);
        const auto t0 = std::chrono::steady_clock::now();
        const double c0 = cpu_seconds();
        const varbo::TrialRecord t = st.ask(1).at(0);
        warm_wall.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
        warm_cpu.push_back(cpu_seconds() - c0);
        fit.push_back(t.fit_seconds + t.acquisition_seconds);
        warm_x = t.x;
      }
      fresh_copy();
      {
        varbo::Study st = varbo::Study::open(copy);
        step(st);
      }
      const auto t0 = std::chrono::steady_clock::now();
      const double c0 = cpu_seconds();
      varbo::Study st = varbo::Study::open(copy);
      const varbo::TrialRecord t = st.ask(1).at(0);
      cold_wall.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      cold_cpu.push_back(cpu_seconds() - c0);
      if (t.x != warm_x) ++mismatches;
    }
    fs::remove_all(scratch);
    double load[1] = {0};
    getloadavg(load, 1);
    std::printf("%s: %d paired rounds, load %.1f; medians, ms (wall, CPU); %d cold trials differing from the warm one\n",
                db.c_str(), repeats, load[0], mismatches);
    std::printf("| warm ask (one iteration) | cold Study::open + ask | ratio wall, CPU | the trial's fit + acquisition "
                "(wall) |\n|---|---|---|---|\n");
    std::printf("| %.2f, %.2f | %.2f, %.2f | %.2f×, %.2f× | %.2f |\n", 1e3 * median(warm_wall), 1e3 * median(warm_cpu),
                1e3 * median(cold_wall), 1e3 * median(cold_cpu), median(cold_wall) / median(warm_wall),
                median(cold_cpu) / median(warm_cpu), 1e3 * median(fit));
    return 0;
  }
  std::vector<double> open_wall, open_cpu, ask_wall, ask_cpu, both_wall, both_cpu, fit_acq;
  for (int r = 0; r < repeats; ++r) {
    fresh_copy();
    const auto t0 = std::chrono::steady_clock::now();
    const double c0 = cpu_seconds();
    varbo::Study s = varbo::Study::open(copy);
    const auto t1 = std::chrono::steady_clock::now();
    const double c1 = cpu_seconds();
    const varbo::TrialRecord t = s.ask(1).at(0);
    const auto t2 = std::chrono::steady_clock::now();
    const double c2 = cpu_seconds();
    open_wall.push_back(std::chrono::duration<double>(t1 - t0).count());
    ask_wall.push_back(std::chrono::duration<double>(t2 - t1).count());
    both_wall.push_back(std::chrono::duration<double>(t2 - t0).count());
    open_cpu.push_back(c1 - c0);
    ask_cpu.push_back(c2 - c1);
    both_cpu.push_back(c2 - c0);
    fit_acq.push_back(t.fit_seconds + t.acquisition_seconds);
    if (url) s.tell(t.id, s.task().evaluate(t.theta, rng).cost);
  }
  fs::remove_all(scratch);
  double load[1] = {0};
  getloadavg(load, 1);
  std::printf("%s: %d cold opens, load %.1f; medians, ms (wall, CPU)\n", db.c_str(), repeats, load[0]);
  std::printf("| Study::open | ask(1) | open + ask | the trial's fit + acquisition (wall) |\n|---|---|---|---|\n");
  std::printf("| %.2f, %.2f | %.2f, %.2f | %.2f, %.2f | %.2f |\n", 1e3 * median(open_wall), 1e3 * median(open_cpu),
              1e3 * median(ask_wall), 1e3 * median(ask_cpu), 1e3 * median(both_wall), 1e3 * median(both_cpu),
              1e3 * median(fit_acq));
  return 0;
}
