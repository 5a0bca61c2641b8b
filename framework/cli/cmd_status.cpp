// `varbo status STUDY.db` (a table of the study) and `varbo export STUDY.db --csv`.
#include <fmt/format.h>

#include <filesystem>

#include <cmath>
#include <algorithm>
#include <cstdio>
#include <fstream>

#include "commands.hpp"
#include "output_guard.hpp"
#include "varbo/csv.hpp"
#include "varbo/errors.hpp"
#include "varbo/host_task.hpp"
#include "varbo/study_api.hpp"
#include "varbo/text.hpp"

namespace varbo::cli {

namespace {

std::string theta_text(const Vec& theta, const std::vector<std::string>& names, const SharedSpace& space = nullptr) {
  std::string s;
  for (Index i = 0; i < theta.size(); ++i)
    s += space ? fmt::format("{}{}={}", i ? " " : "", names[static_cast<std::size_t>(i)],
                             space->format_value(static_cast<std::size_t>(i), theta[i]))  // labels, integers
               : fmt::format("{}{}={}", i ? " " : "", names[static_cast<std::size_t>(i)], exact(theta[i]));
  // Every digit (shortest round-trip form): at 6 digits the trials of [1e6, 1e6 + 1] all read 1e+06, and a θ copied
  // into `observe new --theta` landed elsewhere (red team, session 30). Names and labels may hold control
  // characters: shown escaped, never sent to the terminal.
  return terminal_line(s);
}

std::string csv_cell(const std::string& s) { return csv_text(s); }

/// Studies varbo.minimize wrote name the task `python`, which only the Python module evaluates: its domain is
/// enough to show and export them.
void read_only_components(Registry& registry) { add_host_python_task(registry); }

/// A run folder stands for its study (`varbo status runs/gait`), as `varbo dashboard` and `varbo run --resume` take
/// it; the commands that only read had refused it (red team, session 24). A folder without one is left to the
/// store's own message.
std::string study_of(const std::string& arg) {
  std::error_code ec;
  const std::filesystem::path inside = std::filesystem::path(arg) / "study.db";
  return std::filesystem::is_directory(arg, ec) && std::filesystem::is_regular_file(inside, ec) ? inside.string() : arg;
}

}  // namespace

Runner add_status(CLI::App& app) {
  auto* cmd = app.add_subcommand("status", "Show a study: trials by state, best so far, pending trials");
  auto store = std::make_shared<std::string>();
  cmd->add_option("store", *store, "study file, or postgresql://...?study=NAME URL")->required();
  return [store]() {
    const std::string address = study_of(*store);
    Study s = Study::open(address, read_only_components);
    const auto trials = s.trials();
    const auto& names = s.domain().names;
    Index n[4] = {0, 0, 0, 0};
    for (const auto& t : trials) ++n[static_cast<int>(t.state)];
    const Index finished = n[1] + n[2];
    std::printf("study %s\n  task %s, algorithm %s, seed %llu\n", terminal_line(s.store().location()).c_str(),
                s.config().task.info->name.c_str(),
                s.config().algorithm.info->name.c_str(), static_cast<unsigned long long>(s.config().seed));
    std::printf("  trials     %zu: %ld complete, %ld failed, %ld pending, %ld abandoned (budget %ld, %ld left)\n",
                trials.size(), static_cast<long>(n[1]), static_cast<long>(n[2]), static_cast<long>(n[0]),
                static_cast<long>(n[3]), static_cast<long>(s.config().budget),
                static_cast<long>(std::max<Index>(0, s.config().budget - finished - n[0])));
    if (auto b = s.best())
      std::printf("  best       trial %lld: cost %.8g at %s\n", static_cast<long long>(b->id), b->cost,
                  theta_text(b->theta, names, s.space()).c_str());
    else
      std::printf("  best       (no complete trial yet)\n");
    const double now = unix_time();
    if (n[0] > 0) {
      std::printf("  pending:\n    %-6s %-24s %10s  %s\n", "id", "worker", "age [s]", "theta");
      for (const auto& t : trials)
        if (t.state == TrialState::Pending)
          std::printf("    %-6lld %-24s %10.0f  %s\n", static_cast<long long>(t.id), terminal_line(t.worker).c_str(),
                      now - t.created_at, theta_text(t.theta, names, s.space()).c_str());
    }
    // Workers that send heartbeats (`varbo worker`): a running one silent past heartbeat_timeout is presumed dead,
    // and the next ask abandons its pending trials.
    const auto workers = s.store().workers();
    if (!workers.empty()) {
      std::printf("  workers (heartbeat_timeout %g s):\n    %-40s %-8s %14s  %s\n", s.config().heartbeat_timeout, "id",
                  "state", "heartbeat [s]", "pending");
      for (const auto& w : workers) {
        long pending = 0;
        for (const auto& t : trials) pending += t.state == TrialState::Pending && t.worker == w.id;
        const bool silent = w.state == "running" && s.config().heartbeat_timeout > 0 &&
                            now - w.heartbeat_at > s.config().heartbeat_timeout;
        // A worker of this host whose process is gone (SIGKILL) read "running, 1 s ago" (red team, session 34).
        const bool gone = w.state == "running" && !silent && worker_process_gone(w.id);
        std::printf("    %-40s %-8s %10.0f ago  %ld%s\n", terminal_line(w.id).c_str(),
                    silent ? "silent" : gone ? "gone" : w.state.c_str(), now - w.heartbeat_at, pending,
                    silent && pending ? " (abandoned at the next ask)"
                    : gone && pending ? " (its process has ended: `varbo abandon` frees its trials)"
                                      : "");
      }
    }
    std::printf("  recent:\n    %-6s %-10s %-10s %14s  %s\n", "id", "state", "phase", "cost", "theta");
    const std::size_t first = trials.size() > 10 ? trials.size() - 10 : 0;
    for (std::size_t i = first; i < trials.size(); ++i) {
      const auto& t = trials[i];
      std::printf("    %-6lld %-10s %-10s %14.8g  %s%s\n", static_cast<long long>(t.id), state_name(t.state).c_str(),
                  t.phase.c_str(), t.state == TrialState::Complete ? t.cost : std::nan(""), theta_text(t.theta, names, s.space()).c_str(),
                  // A failure reason is anyone's text (a worker, a task): an escape sequence in it must not reach the
                  // terminal (`varbo fail --reason $'\e[2J'` cleared the screen of whoever ran `varbo status`).
                  t.error.empty() ? "" : ("  (" + terminal_line(t.error) + ")").c_str());
    }
    return 0;
  };
}

Runner add_export(CLI::App& app) {
  auto* cmd = app.add_subcommand("export", "Export every trial of a study");
  struct Args {
    std::string store, output;
    bool csv = false;
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("store", a->store, "study file, or postgresql://...?study=NAME URL")->required();
  cmd->add_flag("--csv", a->csv, "CSV with a header row (the only format so far)")->required();
  cmd->add_option("-o,--output", a->output, "file to write, - for standard output (the default)");
  return [a]() {
    Study s = Study::open(study_of(a->store), read_only_components);
    const auto trials = s.trials();
    std::vector<std::string> comps;
    for (const auto& t : trials)
      for (const auto& [name, v] : t.components)
        if (std::find(comps.begin(), comps.end(), name) == comps.end()) comps.push_back(name);
    std::string out = "id,state,phase";
    for (const auto& n : s.domain().names) out.append(",").append(csv_cell(n));
    out += ",cost";
    for (const auto& c : comps) out.append(",").append(csv_cell(c));
    out += ",error,worker,created_at,finished_at,finish_seq\n";
    for (const auto& t : trials) {
      out += fmt::format("{},{},{}", t.id, state_name(t.state), csv_cell(t.phase));
      for (Index i = 0; i < t.theta.size(); ++i)  // labels for categories when the study declares parameters
        out.append(",").append(s.space() ? csv_cell(s.space()->format_value(static_cast<std::size_t>(i), t.theta[i]))
                                         : exact(t.theta[i]));
      // Only a complete trial has a cost (a failed one recorded by a worker before session 20 stored 0).
      out.append(",").append(t.state != TrialState::Complete || std::isnan(t.cost) ? std::string("nan") : exact(t.cost));
      for (const auto& c : comps) {
        std::string v = "nan";
        for (const auto& [name, value] : t.components)
          if (name == c) v = exact(value);
        out.append(",").append(v);
      }
      out += fmt::format(",{},{},{:.3f},{:.3f},{}\n", csv_cell(t.error), csv_cell(t.worker), t.created_at,
                         t.finished_at, t.finish_seq);
    }
    if (a->output.empty()) {
      std::fwrite(out.data(), 1, out.size(), stdout);
    } else {
      refuse_to_write_over_a_study(a->output, "-o");
      refuse_to_write_over_a_run_file(a->output, "-o");
      write_output(a->output, out, "the export");
    }
    return 0;
  };
}

}  // namespace varbo::cli
