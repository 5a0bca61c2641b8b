// `varbo worker STUDY --command CMD`: the loop a user starts on each machine of a study — suggest, run the command
// like the `external` task (it is that task: JSON on stdin, cost on stdout, timeout, whole process tree killed,
// failures recorded), observe, repeat until the budget is used. A heartbeat thread keeps the worker's row fresh
// so that other processes abandon its trial only when it is really gone (docs/studies.md, "Workers").
#include <fmt/format.h>
#include <signal.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <thread>

#include "varbo/background_ticker.hpp"
#include "varbo/run_liveness.hpp"
#include "cli_parse.hpp"
#include "commands.hpp"
#include "varbo/csv.hpp"
#include "varbo/errors.hpp"
#include "varbo/interrupt.hpp"
#include "varbo/log.hpp"
#include "varbo/store_retry.hpp"
#include "varbo/study_api.hpp"
#include "varbo/text.hpp"

namespace varbo::cli {

namespace {

/// "(0.226, 0.55)": a trial's θ as the task received it, every digit.
std::string theta_text(const Vec& theta) {
  std::string s = "(";
  for (Index i = 0; i < theta.size(); ++i) s += (i ? ", " : "") + exact(theta[i]);
  return s + ")";
}

std::atomic<int> g_stop{0};
constexpr int kStopSignals[] = {SIGTERM, SIGINT, SIGHUP, SIGQUIT};
constexpr int kStops = static_cast<int>(sizeof kStopSignals / sizeof kStopSignals[0]);
struct sigaction g_interrupt_action[kStops];  // varbo's interrupt handlers (interrupt.hpp), armed by the first signal

extern "C" void on_stop_signal(int sig) {
  int expected = 0;
  g_stop.compare_exchange_strong(expected, sig);
  // The next signal goes to varbo's interrupt handler: it stops the running command (its whole tree is killed)
  // and the trial is recorded abandoned. Before, a second Ctrl-C did nothing and the trial ran to its timeout
  // (600 s by default). sigaction is async-signal-safe.
  for (int i = 0; i < kStops; ++i) sigaction(kStopSignals[i], &g_interrupt_action[i], nullptr);
}

/// SIGTERM, SIGINT, SIGHUP, SIGQUIT: finish the current trial, record it, then stop (exit 128 + signal). A second one
/// stops the running command at once (its trial is recorded abandoned, and will be suggested again); a third
/// kills the worker (interrupt.hpp's handlers are one-shot).
void install_stop_handlers() {
  install_interrupt_handlers();
  for (int i = 0; i < kStops; ++i) sigaction(kStopSignals[i], nullptr, &g_interrupt_action[i]);
  struct sigaction sa{};
  sa.sa_handler = on_stop_signal;
  sigemptyset(&sa.sa_mask);
  for (int s : kStopSignals) sigaddset(&sa.sa_mask, s);
  sa.sa_flags = SA_RESTART;
  for (int s : kStopSignals)
    if (!stop_signal_ignored(s)) sigaction(s, &sa, nullptr);  // nohup's SIGHUP stays ignored
}

/// The worker's task from its YAML, resolved and built through the registry like any configured task, and given
/// the study's typed parameters when it has them (then the task sends "params").
std::unique_ptr<Task> build_task(const Study& study, const YAML::Node& n, const std::string& origin) {
  YAML::Emitter em;
  em << YAML::Flow << n;
  const ResolvedComponent spec = study.registry().resolve(Kind::Task, ConfigNode::parse(em.c_str(), origin));
  BuildContext ctx;
  ctx.seed = study.config().seed;
  std::unique_ptr<Task> task = study.registry().create<Task>(spec, ctx);
  if (study.space())
    if (auto* aware = dynamic_cast<SpaceAware*>(task.get())) aware->set_search_space(study.space());
  return task;
}

/// A plain `external` task running `command` on the study's domain (a study whose own task is not external).
std::unique_ptr<Task> external_task(const Study& study, const std::string& command, double timeout, double grace) {
  YAML::Node n(YAML::NodeType::Map);
  n["type"] = "external";
  n["command"] = command;
  if (!study.space()) {  // typed parameters define the domain themselves
    const Domain& d = study.domain();
    for (Index i = 0; i < d.box.dim(); ++i) {
      n["lower"].push_back(exact(d.box.lower[i]));  // exact(): the bounds round-trip through the text
      n["upper"].push_back(exact(d.box.upper[i]));
    }
    for (const auto& name : d.names) n["names"].push_back(name);
  }
  n["timeout"] = exact(timeout);
  n["grace"] = exact(grace);
  return build_task(study, n, "<varbo worker --command>");
}

/// The study's own `external` task, its settings as the study declares them — input (json or args), timeout,
/// grace, workdir, containment, components — with --command, --timeout and --grace replacing theirs when given.
/// Before, a worker always built a plain task from --command: `input: args` was ignored (the command got no
/// arguments, θ arrived on stdin) and the study's timeout was replaced by the worker's 600 s default.
std::unique_ptr<Task> study_external_task(const Study& study, const std::string& command, const std::string& timeout,
                                          const std::string& grace) {
  YAML::Node n = YAML::Clone(study.config().task.source.yaml());
  if (!command.empty()) n["command"] = command;
  if (!timeout.empty()) n["timeout"] = parse_number(timeout, "--timeout");
  if (!grace.empty()) n["grace"] = parse_number(grace, "--grace");
  return build_task(study, n, "<the study's task, with varbo worker's options>");
}

/// Refreshes the worker's heartbeat every `interval` seconds on its own connection to the store, so that a
/// long trial keeps its worker alive.
/// Heartbeats on the thread's own store connection, every `interval` seconds until destroyed. A connection that
/// cannot be made is tried again at the next beat: before, a failure at the first beat (a database restart as
/// the worker started) stopped the heartbeats for good, and the live worker's trials were abandoned and run again
/// elsewhere.
std::unique_ptr<BackgroundTicker> start_heartbeats(const std::string& path, const std::string& worker, double interval) {
  auto store = std::make_shared<std::unique_ptr<StudyStore>>();
  auto said = std::make_shared<bool>(false);
  return std::make_unique<BackgroundTicker>(
      [interval](int k) { return (k + 1) * interval; },
      [store, said, path, worker](int) {
        if (!*store) {
          try {
            *store = open_store(path);
            if (std::exchange(*said, false)) log_warn("worker {}: heartbeats resumed", worker);
          } catch (const Error& e) {
            note_store_unreachable();
            if (!std::exchange(*said, true))
              log_warn("worker {}: heartbeat not recorded: {}; trying again at every beat", worker, e.what());
            return true;
          }
        }
        const auto [host, pid] = worker_host_pid(worker);
        WorkerRecord w;
        w.id = worker;
        w.host = host;
        w.pid = pid;
        w.started_at = w.heartbeat_at = unix_time();
        try {
          (*store)->transaction([&] { (*store)->put_worker(w); });
          if (std::exchange(*said, false)) log_warn("worker {}: heartbeats resumed", worker);
        } catch (const Error& e) {
          note_store_unreachable();  // others' silence is not judged longer than ours lasted (store.hpp)
          // Said once per outage, not at every beat (every 0.75 s with heartbeat_timeout 3; red team, session 25).
          if (!std::exchange(*said, true))
            log_warn("worker {}: heartbeat not recorded: {}; trying again at every beat", worker, e.what());
          else
            log_debug("worker {}: heartbeat not recorded: {}", worker, e.what());
        }
        return true;
      });
}

/// store_retry.hpp's retry, stopped by a stop signal: a worker of a days-long study outlives a database restart or a
/// network cut.
template <class F>
auto retrying(double limit, const std::string& worker, F&& f) -> decltype(f()) {
  return retry_while_unreachable(limit, "worker " + worker, [] { return g_stop.load() != 0; }, std::forward<F>(f));
}

}  // namespace

Runner add_worker(CLI::App& app) {
  auto* cmd = app.add_subcommand("worker", "Work on a study: suggest, run a command on θ, record its cost, repeat "
                                           "until the budget is used");
  struct Args {
    std::string store, command, timeout, grace, host_id, reconnect = "120";
    long long max_trials = 0;
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("store", a->store, "study file, or postgresql://...?study=NAME URL")->required();
  cmd->add_option("--command", a->command,
                  "shell command evaluating one θ, as the external task runs it: {\"theta\": [...], \"names\": "
                  "[...], \"trial\": k, \"id\": k} on stdin, the cost (or {\"cost\": c, \"components\": {...}}) on "
                  "the last line of stdout (default: the study's command, when its task is external; its other "
                  "settings — input, timeout, grace, workdir — apply either way)");
  cmd->add_option("--max-trials", a->max_trials, "stop after this many trials (0 = until the budget is used)")
      ->check(integer_in(0, 1000000000));
  cmd->add_option("--host-id", a->host_id, "the host part of this worker's id (default $VARBO_HOST_ID, else the host "
                                           "name); workers are told apart by host:pid:nonce");
  cmd->add_option("--reconnect-timeout", a->reconnect,
                  "seconds to keep retrying (with backoff) when the database server is unreachable or the connection "
                  "drops, before exiting 2 (PostgreSQL studies; 0 = exit at once)");
  cmd->add_option("--timeout", a->timeout, "seconds before the command and its whole process tree are killed "
                                           "(a failed trial; default: the study's external task's, else 600)");
  cmd->add_option("--grace", a->grace, "seconds between SIGTERM and SIGKILL when a trial is stopped (default: the "
                                       "study's external task's, else 0.2)");
  return [a, cmd]() {
    if (!a->timeout.empty()) {
      const double timeout = parse_number(a->timeout, "--timeout");
      if (!(timeout > 0) || !std::isfinite(timeout))
        throw InputError(fmt::format("--timeout: expected a finite number of seconds > 0, got '{}'", a->timeout));
    }
    if (!a->grace.empty()) {
      const double grace = parse_number(a->grace, "--grace");
      if (!(grace >= 0) || !(grace <= 3600))
        throw InputError(fmt::format("--grace: expected a number of seconds from 0 to 3600, got '{}'", a->grace));
    }
    // Blank too: it reached the task's own check, whose message named a synthesized "<varbo worker --command>:1:27".
    if (cmd->count("--command") > 0 && a->command.find_first_not_of(" \t\r\n") == std::string::npos)
      throw InputError("--command: expected a shell command, got an empty one");
    const double reconnect = parse_number(a->reconnect, "--reconnect-timeout");
    if (!(reconnect >= 0) || !std::isfinite(reconnect))
      throw InputError(fmt::format("--reconnect-timeout: expected a number of seconds ≥ 0, got '{}'", a->reconnect));
    // A worker started with its machine (a robot booting after a power cut) may come up before the database
    // server: it waits for it as for an outage later on. A server that refuses it (password, no such database)
    // is an error at once.
    install_stop_handlers();
    Study study = retrying(reconnect, "(starting)", [&] { return Study::open(a->store); });
    const std::string id = new_worker_id(a->host_id);
    study.set_worker(id);
    const ResolvedComponent& own = study.config().task;
    std::unique_ptr<Task> task;
    if (own.info && own.info->name == "external") {
      task = study_external_task(study, a->command, a->timeout, a->grace);
    } else {
      if (a->command.empty())
        throw InputError(fmt::format("{}: the study's task is '{}', not an external command: give the command that "
                                     "evaluates a θ with --command",
                                     study.store().location(), own.info ? own.info->name : "?"));
      task = external_task(study, a->command, a->timeout.empty() ? 600.0 : parse_number(a->timeout, "--timeout"),
                           a->grace.empty() ? 0.2 : parse_number(a->grace, "--grace"));
    }
    const double hb = study.config().heartbeat_timeout > 0 ? std::max(0.05, study.config().heartbeat_timeout / 4) : 10.0;
    study.heartbeat();
    auto beats = start_heartbeats(a->store, id, hb);
    // The store's location everywhere it is shown: a PostgreSQL URL's password as *** (logs keep it).
    const std::string where = study.store().location();
    // The banner, a line per trial and the closing count are progress: `varbo -q worker` keeps only warnings and
    // errors (red team, session 29: -q silenced none of them).
    const bool progress = log_level() <= LogLevel::Info;
    if (progress)
      std::fprintf(stderr, "varbo worker %s on %s (heartbeat every %.3g s)\n", id.c_str(), where.c_str(), hb);
    long long done = 0;
    int exit_code = 0;
    Index failures_in_a_row = 0;
    std::vector<std::int64_t> streak_ids;  // their ids
    std::vector<std::string> waiting_for;  // the pending trials last reported
    RunSilence run_silence;                 // of the run sessions whose trials are pending
    // Then its command, which the run's supervisor stops, is gone `grace` later (command_stop_seconds).
    const double liveness = (study.config().heartbeat_timeout > 0 ? study.config().heartbeat_timeout : 60.0) +
                            command_stop_seconds(study.config().task);
    while (a->max_trials == 0 || done < a->max_trials) {
      if (const int sig = g_stop.load()) {
        exit_code = 128 + sig;
        break;
      }
      const std::vector<TrialRecord> asked = retrying(reconnect, id, [&] { return study.ask(1); });
      if (asked.empty()) {
        // The budget is used, or held by trials pending elsewhere: wait while those may still finish or be
        // abandoned (their worker silent), then ask again.
        // A `varbo run` that was killed (SIGKILL, a crash) left its trial pending, and a run sends no heartbeats:
        // this worker waited for it all night (red team, session 46). With no run holding the study's run lock
        // (its command's supervisor keeps it until the command is gone), such a trial is abandoned, as a resumed
        // run or `varbo abandon` would, and asked again.
        // On a database study the lock is a server session, which a server restart frees while the run lives on
        // (red team, session 49: this worker ran the live run's θ again): the run must also have been silent for
        // the liveness window (run_liveness.hpp).
        // Every read and write here rides out an outage as the ask does: a worker waiting through a server
        // restart exited 2 on "cannot read trials" (session 49).
        std::size_t taken_over = 0;
        std::vector<std::string> others;
        retrying(reconnect, id, [&] {
          taken_over = 0;
          others.clear();
          std::vector<std::int64_t> of_dead_runs;
          for (const auto& t : study.store().pending_trials())
            if (t.worker != id && !t.worker.empty() && study.store().meta("run_worker/" + t.worker) &&
                (!is_database_url(where) || run_silence.seconds(study.store(), t.worker) > liveness))
              of_dead_runs.push_back(t.id);
          if (!of_dead_runs.empty() && !run_is_live(a->store)) {  // not `where`: its password is ***
            taken_over = study
                             .abandon_where(
                                 [&](const TrialRecord& p) {
                                   return std::find(of_dead_runs.begin(), of_dead_runs.end(), p.id) !=
                                          of_dead_runs.end();
                                 },
                                 "abandoned: the `varbo run` that held it is gone (its run lock is free)")
                             .size();
            if (taken_over > 0) return 0;
          }
          for (const auto& t : study.store().pending_trials())
            if (t.worker != id)
              others.push_back(fmt::format("{} ({})", t.id, t.worker.empty() ? "no worker" : t.worker));
          return 0;
        });
        if (taken_over > 0) {
          std::fprintf(stderr, "varbo worker: abandoned %zu trial(s) left pending by a `varbo run` that is gone\n",
                       taken_over);
          continue;
        }
        if (others.empty()) break;
        if (others != waiting_for) {
          // Said once per change: a worker that only sleeps looked hung (trials left pending by `varbo suggest`
          // wait for an observe, or for `varbo abandon`).
          std::fprintf(stderr,
                       "varbo worker: the budget is held by %zu trial(s) pending elsewhere: %s; waiting for them to "
                       "be observed, failed or abandoned (`varbo abandon %s --id ID`; a trial a worker holds is also "
                       "abandoned once that worker is silent for the heartbeat timeout)\n",
                       others.size(), join(others).c_str(), shell_word(where).c_str());
          waiting_for = others;
        }
        std::this_thread::sleep_for(std::chrono::duration<double>(std::min(hb, 0.25)));
        continue;
      }
      const TrialRecord& t = asked.front();
      Rng rng = Rng(study.config().seed).stream(0x7a5c).stream(static_cast<std::uint64_t>(t.id));
      const auto t0 = std::chrono::steady_clock::now();
      bool stopped_by_signal = false;
      if (auto* aware = dynamic_cast<TrialAware*>(task.get())) aware->set_next_trial(static_cast<long>(t.id), static_cast<long>(t.id));
      Evaluation e;
      try {
        e = task->evaluate(t.theta, rng);
      } catch (const TaskSetupError& err) {
        // Not a result of θ (errors.hpp): abandoned, and this worker stops; its trial is suggested again.
        retrying(reconnect, id, [&] {
          return study.abandon_where([&](const TrialRecord& p) { return p.id == t.id; }, "the task could not run");
        });
        throw InputError(fmt::format("trial {}: {}; the trial is abandoned, not failed", t.id, err.what()));
      } catch (const Interrupted& err) {  // stopped by the signal: no result (task.hpp)
        e = Evaluation{};
        e.ok = false;
        e.error = err.what();
        stopped_by_signal = true;
      } catch (const std::exception& err) {  // a failed trial, never a crash (task.hpp)
        e = Evaluation{};
        e.ok = false;
        e.error = err.what();
      }
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      // Only a trial the signal cut short: one that failed on its own (a timeout) stays failed (session 34).
      if (const int sig = interrupt_signal(); sig != 0 && stopped_by_signal) {
        // Stopped by a second signal: no result. Abandoned, not failed, as `varbo run` does: it does not count
        // against the budget and the failure model learns nothing false from it.
        const std::string reason = fmt::format("interrupted by {}", signal_name(sig));
        retrying(reconnect, id, [&] {
          return study.abandon_where([&](const TrialRecord& p) { return p.id == t.id; }, reason);
        });
        // The evaluation's error is most often the reason itself: said once ("interrupted by SIGINT (interrupted
        // by SIGINT)", red team, session 37).
        const std::string detail = safe_text(e.error, 200);
        const std::string more = detail.empty() || detail == reason ? "" : " (" + detail + ")";
        std::fprintf(stderr, "trial %lld (%s): abandoned: %s%s\n", static_cast<long long>(t.id), t.phase.c_str(),
                     reason.c_str(), more.c_str());
        exit_code = 128 + sig;
        break;
      }
      if (e.ok && !std::isfinite(e.cost)) {
        e.ok = false;
        e.error = fmt::format("non-finite cost {}", e.cost);
      }
      int taken_elsewhere = 0;
      try {
      taken_elsewhere = retrying(reconnect, id, [&] {
        try {
          study.record(t.id, e, seconds);
        } catch (const InputError&) {
          // A commit cut by a lost connection may have landed: then the retry finds the trial finished.
          const auto stored = study.store().trial(t.id);
          const bool landed = stored && (e.ok ? stored->state == TrialState::Complete && stored->cost == e.cost
                                              : stored->state == TrialState::Failed);
          if (landed) return 0;
          // Recorded by someone else meanwhile (an operator's `varbo fail` when the robot fell): theirs stands.
          // Before, the worker exited here and left the rest of the night's trials unrun.
          if (stored && (stored->state == TrialState::Complete || stored->state == TrialState::Failed)) {
            std::fprintf(stderr,
                         "trial %lld (%s): already recorded as %s by another process; this worker's result (%s) is "
                         "not stored\n",
                         static_cast<long long>(t.id), t.phase.c_str(),
                         stored->state == TrialState::Complete ? ("complete, cost " + exact(stored->cost)).c_str()
                                                               : "failed",
                         e.ok ? ("cost " + exact(e.cost)).c_str() : "failed");
            return 1;
          }
          throw;
        }
        return 0;
      });
      } catch (const std::exception& err) {
        // The trial ran (on a robot, perhaps for an hour) but its result is not stored (a full disk, a store
        // gone): say it, with the command that records it once the cause is fixed. It stays pending.
        std::string cmd = e.ok ? fmt::format("varbo observe {} {} {}", shell_word(where), t.id, exact(e.cost))
                               : fmt::format("varbo fail {} {} --reason 'recorded by hand'", shell_word(where), t.id);
        if (e.ok)
          for (const auto& [name, value] : e.components)
            cmd += " --component " + shell_word(fmt::format("{}={}", name, exact(value)));
        // Where the study file was replaced, the file of that name is another study now: recording there would put
        // this cost on whatever its trial of this id is (audit, session 45). The θ is said, so the result can be
        // matched by hand.
        const bool replaced = dynamic_cast<const StudyFileChangedError*>(&err) != nullptr;
        std::fprintf(stderr, "trial %lld (%s) at θ = %s was evaluated but its result could not be recorded: %s; %s%s\n",
                     static_cast<long long>(t.id), e.ok ? ("cost " + exact(e.cost)).c_str() : "failed",
                     // Typed as declared: a category by its label, not its index (red team, session 46).
                     terminal_line(study.space() && t.theta.allFinite() ? study.space()->params(t.theta).to_json()
                                                                        : theta_text(t.theta))
                         .c_str(),
                     safe_text(err.what(), 300).c_str(),
                     replaced ? "it belongs to the study that was at that path when this worker opened it, not to the "
                                "file there now (do not record it there)"
                              : "once the cause is fixed, record it with: ",
                     replaced ? "" : cmd.c_str());
        throw;
      }
      ++done;
      if (taken_elsewhere) continue;
      if (progress || !e.ok)
        std::fprintf(stderr, "trial %lld (%s): %s\n", static_cast<long long>(t.id), t.phase.c_str(),
                     e.ok ? ("cost " + exact(e.cost)).c_str() : ("failed: " + safe_text(e.error, 200)).c_str());
      // This worker's own trials: a rig that fails every trial (unplugged, E-stop) stops instead of using the
      // study's budget up in a second; the other workers go on.
      failures_in_a_row = e.ok ? 0 : failures_in_a_row + 1;
      if (e.ok) streak_ids.clear();
      else streak_ids.push_back(t.id);
      const Index limit = study.config().stop_after_failures;
      if (limit > 0 && failures_in_a_row >= limit) {
        // The study may be over with this trial: then there is nothing to start again, as `varbo run` says in the
        // same state (exit 0). It said "start the worker again" with exit 2 (red team, session 31).
        Index finished = 0;
        for (const auto& r : study.trials())
          finished += r.state == TrialState::Complete || r.state == TrialState::Failed;
        if (finished >= study.config().budget) {
          std::fprintf(stderr,
                       "varbo worker %s: the budget is used; the last %lld trials failed in a row, the last: %s\n",
                       id.c_str(), static_cast<long long>(failures_in_a_row), safe_text(e.error, 300).c_str());
          break;
        }
        // Those failures teach bo's failure model that their θ fail, as `varbo run`'s stop message says (red team,
        // session 49: the worker's did not name the command that takes them back).
        std::string retract;
        if (const auto* info = study.config().algorithm.info; info && info->name == "bo") {
          retract = "; if the rig, not θ, failed these trials, take them back first, or bo keeps their "
                    "neighbourhoods closed: varbo retract " + shell_word(where);
          for (const auto sid : streak_ids) retract += fmt::format(" --id {}", sid);
        }
        std::fprintf(stderr,
                     "varbo worker %s: stopping after %lld failed trials in a row (stop_after_failures: %lld), the "
                     "last: %s; check this machine's setup, then start the worker again%s\n",
                     id.c_str(), static_cast<long long>(failures_in_a_row), static_cast<long long>(limit),
                     safe_text(e.error, 300).c_str(), retract.c_str());
        exit_code = 2;
        break;
      }
    }
    beats.reset();  // first: a beat after it would mark the worker running again
    study.heartbeat("stopped");
    if (progress || exit_code != 0)
      std::fprintf(stderr, "varbo worker %s: %lld trial(s) done%s\n", id.c_str(), done,
                   exit_code > 128 ? fmt::format(", stopped by signal {}", exit_code - 128).c_str() : "");
    return exit_code;
  };
}

}  // namespace varbo::cli
