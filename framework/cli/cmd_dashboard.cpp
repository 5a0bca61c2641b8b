// `varbo dashboard STUDY [--port 8080] [--host 127.0.0.1]`: a live view of a study in the browser (docs/dashboard.md):
// history, trials, model slices and maps, and the risk factor κ chosen after learning with a slider (Kuindersma
// 2013, section 3.2), served read-only from the study store while workers write to it.
#include <malloc.h>
#include <fmt/format.h>

#include <unistd.h>

#include <cerrno>
#include <cstdio>

#include "cli_parse.hpp"
#include "commands.hpp"
#include "dashboard/dashboard_server.hpp"
#include "varbo/errors.hpp"
#include "varbo/interrupt.hpp"
#include "varbo/log.hpp"
#include "varbo/parallel.hpp"

namespace varbo::cli {

Runner add_dashboard(CLI::App& app) {
  auto* cmd = app.add_subcommand("dashboard", "Serve a live dashboard of a study (history, trials, model, risk slider)");
  struct Args {
    std::string study, host = "127.0.0.1";
    int port = 8080, threads = 0, nice = 10;
    long long seed = 1;
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("study", a->study, "study file, run folder (its study.db) or postgresql://...?study=NAME URL")
      ->required();
  cmd->add_option("--port", a->port, "TCP port (0: any free port, printed)")->capture_default_str()->check(integer_in(0, 65535));
  cmd->add_option("--host", a->host,
                  "address to listen on; the default serves this machine only (another address exposes the study "
                  "to the network: the dashboard has no authentication)")
      ->capture_default_str();
  cmd->add_option("--seed", a->seed, "seed of the model fit and the κ search (as `varbo select --seed`)")
      ->capture_default_str()
      ->check(integer_in(0, 9223372036854775807LL));
  cmd->add_option("--threads", a->threads, "worker threads of the model work (0 = all)")->check(integer_in(0, 2147483647));
  cmd->add_option("--nice", a->nice,
                  "lower the server's CPU priority by this much (0: unchanged), so that its model fits never slow a "
                  "study running on the same machine")
      ->capture_default_str()
      ->check(integer_in(0, 19));
  return [a]() {
    ThreadLimit limit(a->threads);
    errno = 0;
    if (a->nice > 0 && ::nice(a->nice) == -1 && errno != 0) log_warn("dashboard: could not lower the CPU priority");
    if (a->seed < 0) throw InputError("--seed: expected a non-negative integer");
    DashboardStudy study(a->study, static_cast<std::uint64_t>(a->seed));
    DashboardApi api(study);
    // main() keeps freed blocks for the short commands; a server that lives for days gives them back: large
    // replies are mapped and unmapped, and the heap is trimmed (growing_pool.hpp's on_idle trims the arenas).
    mallopt(M_MMAP_THRESHOLD, 128 * 1024);
    mallopt(M_TRIM_THRESHOLD, 128 * 1024);
    install_interrupt_handlers();  // Ctrl-C, SIGTERM, SIGHUP, SIGQUIT: the server stops and closes the study (exit 128 + signal)
    serve_dashboard(api, a->host, a->port, [&](int port) {
      std::printf("varbo dashboard: serving %s at http://%s:%d/ (Ctrl-C stops)\n", study.shown().c_str(),
                  a->host.find(':') != std::string::npos ? ("[" + a->host + "]").c_str() : a->host.c_str(), port);
      std::fflush(stdout);
    });
    return 0;
  };
}

}  // namespace varbo::cli
