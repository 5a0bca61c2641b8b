// `varbo suggest` against one BO iteration (issue 14, target ≤ 1.5×). One Hartmann-6 bo study (plain
// defaults, seed 1) is driven by an embedded varbo::Study, as `varbo run` does; at N = 50, 100, 200, 400 finished
// trials (or the --at list) --repeats rounds (11 by default), each a `varbo suggest` + `varbo observe` process
// pair then a fresh Study::open + ask + tell in this process, continue it (interleaved, so that both see the same
// machine load). Printed per N: the median wall time of the embedded ask(1) over the 11 iterations just before N
// and the 11 just after the rounds (one BO iteration: fit + acquisition + store), the median wall time of the `varbo suggest`
// process (start-up, plugins, opening the
// study, restoring the saved state, then one iteration), and their ratio; the same in CPU seconds (user + system,
// all threads; for the process, its rusage), which a loaded machine distorts less than wall time; the median
// of each process's wall time minus the fit and acquisition time it recorded for its trial: the fixed cost; and
// the embedded API's cold path: a fresh varbo::Study::open of the study in this process, then ask(1); and the
// 1-minute load average before and after.
//
// The study is a SQLite file in --dir, or a PostgreSQL study with --store 'postgresql://...?study=NAME'.
// --algorithm replaces the plain default `{type: bo}` (e.g. '{type: bo, region: box}': a model of all N points).
//
//   nice -n 15 build/bin/bench_suggest build/bin/varbo [--at 50,100,200,400] [--dir /tmp/x] [--store ADDRESS]
//                                      [--algorithm YAML] [--repeats 11]
#include <fmt/format.h>
#include <malloc.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "process_stats.hpp"
#include "varbo/csv.hpp"
#include "varbo/study_api.hpp"

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

using varbo::bench::cpu_seconds;
using varbo::bench::median;

std::string slurp(const std::string& file) {
  std::ifstream in(file);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// Runs a shell command, exits on failure.
void run(const std::string& cmd) {
  if (std::system(cmd.c_str()) != 0) {
    std::fprintf(stderr, "bench_suggest: command failed: %s\n", cmd.c_str());
    std::exit(1);
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: bench_suggest VARBO_EXE [--at 50,100,200,400] [--dir DIR] [--store ADDRESS] "
                         "[--algorithm YAML] [--repeats R]\n");
    return 2;
  }
  // The embedded iterations run with the allocator settings of the `varbo` executable (framework/cli/main.cpp:
  // freed blocks kept in the heap), so that both sides of the ratio are the same computation on the same heap.
  mallopt(M_MMAP_THRESHOLD, 256 << 20);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  const std::string varbo = argv[1];
  std::vector<long> at = {50, 100, 200, 400};
  std::string store, algorithm = "{type: bo}";
  int repeats = 11;  // rounds per N: a suggest process, then a fresh Study::open + ask
  std::string dir = (std::filesystem::temp_directory_path() / "varbo_bench_suggest").string();
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string key = argv[i], value = argv[i + 1];
    if (key == "--at") {
      at.clear();
      std::stringstream ss(value);
      for (std::string t; std::getline(ss, t, ',');) at.push_back(std::stol(t));
    } else if (key == "--dir") {
      dir = value;
    } else if (key == "--store") {
      store = value;
    } else if (key == "--algorithm") {
      algorithm = value;
    } else if (key == "--repeats") {
      repeats = std::max(1, std::stoi(value));
    }
  }
  constexpr int kIterations = 11;  // embedded iterations timed before N and after the rounds (a fit's cost varies
                                  // 2-3× between neighbours)
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string db = store.empty() ? dir + "/h6.db" : store;
  const long budget = at.back() + (2L * repeats + kIterations + 1) * static_cast<long>(at.size()) + 10;
  varbo::Study study = varbo::Study::create_from_yaml(
      db, fmt::format("task: {{type: hartmann6}}\nbudget: {}\nseed: 1\nalgorithm: {}\n", budget, algorithm));
  varbo::Rng noise(1);
  auto evaluate = [&](const varbo::TrialRecord& t) {
    varbo::Rng r = noise.stream(static_cast<std::uint64_t>(t.id));
    return study.task().evaluate(t.theta, r).cost;
  };
  std::printf("| N | one BO iteration (embedded ask): wall, CPU s | `varbo suggest` process: wall, CPU s | ratio wall, "
              "CPU | process minus its own fit + acquisition: wall s | Study::open + ask in this process: wall, CPU s "
              "| its ratio wall, CPU | load (1 min) |\n|---|---|---|---|---|---|---|---|\n");
  long finished = 0;
  std::vector<double> iteration, iteration_cpu;
  // One embedded ask(1) + tell: a warm iteration (timed when `timed`) of the study's own live algorithm.
  auto embedded_iteration = [&](bool timed) {
    const auto t0 = std::chrono::steady_clock::now();
    const double c0 = cpu_seconds(RUSAGE_SELF);
    const varbo::TrialRecord t = study.ask(1).at(0);
    const double s = seconds_since(t0), c = cpu_seconds(RUSAGE_SELF) - c0;
    if (timed) {
      iteration.push_back(s);
      iteration_cpu.push_back(c);
    }
    study.tell(t.id, evaluate(t));
    ++finished;
  };
  for (const long n : at) {
    iteration.clear();
    iteration_cpu.clear();
    while (finished < n) embedded_iteration(finished >= n - kIterations);
    double load_before[1] = {0}, load_after[1] = {0};
    getloadavg(load_before, 1);
    std::vector<double> suggest, suggest_cpu, overhead, reopen, reopen_cpu;
    for (int r = 0; r < repeats; ++r) {
      const std::string out = dir + "/suggest.json";
      auto t0 = std::chrono::steady_clock::now();
      const double c0 = cpu_seconds(RUSAGE_CHILDREN);
      run(fmt::format("'{}' -q suggest '{}' --json > '{}'", varbo, db, out));
      suggest.push_back(seconds_since(t0));
      suggest_cpu.push_back(cpu_seconds(RUSAGE_CHILDREN) - c0);
      // The trial's id is the number of trials so far; its θ is read back from the store.
      const auto trials = study.trials();
      const varbo::TrialRecord& t = trials.back();
      overhead.push_back(suggest.back() - t.fit_seconds - t.acquisition_seconds);
      run(fmt::format("'{}' -q observe '{}' {} {} > /dev/null", varbo, db, t.id, varbo::exact(evaluate(t))));
      ++finished;
      (void)slurp(out);
      // The embedded API's own cold path: a fresh Study::open of the study in this process, then ask(1).
      t0 = std::chrono::steady_clock::now();
      const double c1 = cpu_seconds(RUSAGE_SELF);
      varbo::Study fresh = varbo::Study::open(db);
      const varbo::TrialRecord f = fresh.ask(1).at(0);
      reopen.push_back(seconds_since(t0));
      reopen_cpu.push_back(cpu_seconds(RUSAGE_SELF) - c1);
      fresh.tell(f.id, evaluate(f));
      ++finished;
    }
    // The live study catches up (a restore: not timed), then warm iterations again.
    embedded_iteration(false);
    for (int i = 0; i < kIterations; ++i) embedded_iteration(true);
    getloadavg(load_after, 1);
    const double it = median(iteration), sg = median(suggest);
    const double itc = median(iteration_cpu), sgc = median(suggest_cpu);
    const double ro = median(reopen), roc = median(reopen_cpu);
    std::printf("| %ld | %.3f, %.3f | %.3f, %.3f | %.2f×, %.2f× | %.3f | %.3f, %.3f | %.2f×, %.2f× | %.1f–%.1f |\n", n,
                it, itc, sg, sgc, sg / it, sgc / itc, median(overhead), ro, roc, ro / it, roc / itc, load_before[0],
                load_after[0]);
    std::fflush(stdout);
  }
  return 0;
}
