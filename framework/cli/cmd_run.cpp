// `varbo run CONFIG.yaml`: run a study to its budget and write the run folder.
#include <fmt/format.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include "cli_parse.hpp"
#include "commands.hpp"
#include "varbo/errors.hpp"
#include "varbo/text.hpp"
#include "varbo/log.hpp"
#include "varbo/interrupt.hpp"
#include "varbo/study.hpp"

namespace varbo::cli {

Runner add_run(CLI::App& app) {
  auto* cmd = app.add_subcommand("run", "Run a study from a YAML configuration");
  struct Args {
    std::string config;
    int threads = -1;
    std::string seed;
    std::string budget;
    std::string output;
    std::string study;
    std::string resume;
    std::string reconnect = "120";
    bool no_progress = false;
    bool overwrite = false;
  };
  auto a = std::make_shared<Args>();
  auto* config = cmd->add_option("config", a->config, "study configuration (YAML)");
  auto* resume = cmd->add_option("--resume", a->resume,
                                 "continue an interrupted run: its folder (holding study.db) or its study file");
  // Not CLI11's excludes ("config excludes --resume"): the message says what each form does (red team, session 46).
  (void)config;
  cmd->add_flag("--overwrite", a->overwrite,
                "replace the study of the run folder even if it holds trials (they are lost)")
      ->excludes(resume);
  cmd->add_option("--study", a->study,
                  "study file of the run (default: <output>/study.db); an existing one is continued");
  cmd->add_option("--threads", a->threads, "worker threads (0 = all cores); overrides the file")->check(integer_in(0, 2147483647));
  auto* seed = cmd->add_option("--seed", a->seed, "random seed (an integer >= 0); overrides the file");
  auto* budget = cmd->add_option("--budget", a->budget, "number of evaluations (an integer >= 1); overrides the file");
  auto* output = cmd->add_option("-o,--output", a->output, "run folder; overrides the file");
  cmd->add_flag("--no-progress", a->no_progress, "no per-trial progress lines");
  cmd->add_option("--reconnect-timeout", a->reconnect,
                  "seconds to keep retrying (with backoff) when the database server is unreachable or the connection "
                  "drops, before the run stops with exit 2 (PostgreSQL studies; 0 = stop at once)");
  return [a, seed, budget, output]() {
    RunOverrides ov;
    ov.reconnect_seconds = parse_number(a->reconnect, "--reconnect-timeout");
    if (!(ov.reconnect_seconds >= 0) || !std::isfinite(ov.reconnect_seconds))
      throw InputError(fmt::format("--reconnect-timeout: expected a number of seconds ≥ 0, got '{}'", a->reconnect));
    if (a->threads >= 0) ov.threads = a->threads;
    if (seed->count() > 0) ov.seed = static_cast<std::uint64_t>(integer_flag(a->seed, "--seed", 0));
    if (budget->count() > 0) ov.budget = integer_flag(a->budget, "--budget", 1);
    if (output->count() > 0 && a->output.find_first_not_of(" \t") == std::string::npos)
      throw InputError("-o/--output: an empty folder name; expected a run folder such as runs/gait");
    if (!a->output.empty()) ov.output = a->output;
    ov.progress = !a->no_progress;
    ov.overwrite = a->overwrite;
    if (!a->study.empty()) ov.store = a->study;
    if (a->config.empty() && a->resume.empty())
      throw InputError("varbo run: give a study configuration (CONFIG.yaml) or --resume RUN_DIR");
    if (!a->config.empty() && !a->resume.empty())
      throw InputError(fmt::format(
          "varbo run: give either a configuration or --resume, not both: `varbo run --resume {0}` continues the run "
          "with the configuration it was created with (--budget may raise its budget); to continue it with a changed "
          "configuration (a larger budget, another stop_after_failures), give that and the run's study: `varbo run "
          "{1} -o {0} --study {0}/study.db` (a change to the task, algorithm or seed is refused as another study)",
          shell_word(a->resume), shell_word(a->config)));
    // Ctrl-C, SIGTERM, SIGHUP, SIGQUIT: the running trial's command is killed with its process tree, the trial is
    // recorded abandoned, and varbo exits with 128 + signal (main.cpp); --resume continues the run.
    install_interrupt_handlers();
    RunSummary s = a->resume.empty() ? run_study_file(a->config, ov) : resume_study(a->resume, ov);
    std::printf("%s", s.report().c_str());
    // Every trial failed: the run is over and recorded (exit 0, as any run whose trials were evaluated), but there
    // is nothing to deploy; say it where a script's log shows it (red team, session 29).
    if (s.evaluations > 0 && !s.best_theta)
      log_warn("every one of the {} trials failed: no cost was observed, nothing to recommend", s.evaluations);
    return 0;
  };
}

}  // namespace varbo::cli
