// How long a trial with many children takes to be stopped once its timeout has passed: run_shell's wall time
// minus the timeout, for containment process_group (tree walk of /proc, token sweep) and cgroup (cgroup.kill).
// A third of the children leave the session with a cleared environment (env -i setsid). The command says when
// all have been started (a file); a repetition where they had not is not counted. After each, no process of
// it may remain (checked from /proc by a marker in the command line).
//
// With `ignore_term` 1 the shell ignores SIGTERM before starting them, so they do too (inherited): the stop then
// takes the 0.2 s grace and SIGKILL.
//
//   bench_kill_tree [repetitions=7] [children=300] [timeout_s=5] [ignore_term=0]
#include <fmt/format.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "process_probe.hpp"
#include "subprocess.hpp"
#include "trial_cgroup.hpp"

using namespace varbo::tasks;

using varbo::test::processes_with;

int main(int argc, char** argv) {
  const int reps = argc > 1 ? std::atoi(argv[1]) : 7;
  const int children = argc > 2 ? std::atoi(argv[2]) : 300;
  const double timeout = argc > 3 ? std::atof(argv[3]) : 5.0;
  const bool ignore_term = argc > 4 && std::atoi(argv[4]) != 0;
  const std::string tmp = std::filesystem::temp_directory_path() / fmt::format("bench_kill_tree_{}", ::getpid());
  std::filesystem::create_directories(tmp);
  fmt::print("{} children{}, timeout {} s, {} repetitions; cgroup: {}\n", children,
             ignore_term ? " ignoring SIGTERM" : "", timeout, reps,
             cgroup_unavailable().empty() ? "available" : cgroup_unavailable());
  int bad = 0;
  for (const Containment c : {Containment::ProcessGroup, Containment::Cgroup}) {
    const char* name = c == Containment::Cgroup ? "cgroup" : "process_group";
    if (c == Containment::Cgroup && !cgroup_unavailable().empty()) continue;
    std::vector<double> kill;
    for (int k = 0; k < reps; ++k) {
      const std::string marker = fmt::format("58.{}{}{}", ::getpid(), static_cast<int>(c), k);
      std::filesystem::remove(tmp + "/ready");
      ProcessOptions po;
      po.timeout_seconds = timeout;
      po.containment = c;
      const ProcessResult r = run_shell(
          fmt::format("{3}i=0; while [ $i -lt {2} ]; do i=$((i+1)); if [ $((i % 3)) -eq 0 ]; then "
                      "env -i setsid /bin/sleep {0} & else /bin/sleep {0} & fi; done; touch {1}/ready; sleep 600",
                      marker, tmp, children, ignore_term ? "trap '' TERM; " : ""),
          "", po);
      const auto left = processes_with(marker);
      if (!left.empty()) {
        ++bad;
        fmt::print("  {} rep {}: {} processes LEFT\n", name, k, left.size());
        for (pid_t p : left) ::kill(p, SIGKILL);  // ours: the marker is unique to this run
      }
      if (!std::filesystem::exists(tmp + "/ready") || !r.timed_out) {
        fmt::print("  {} rep {}: not all children started before the timeout; not counted\n", name, k);
        continue;
      }
      kill.push_back(r.seconds - timeout);
    }
    if (kill.empty()) continue;
    std::vector<double> s = kill;
    std::sort(s.begin(), s.end());
    fmt::print("{:<14} stop after the timeout: median {:.3f} s, min {:.3f}, max {:.3f} (n = {}):", name,
               s[s.size() / 2], s.front(), s.back(), s.size());
    for (double v : kill) fmt::print(" {:.3f}", v);
    fmt::print("\n");
  }
  std::filesystem::remove_all(tmp);
  return bad == 0 ? 0 : 1;
}
