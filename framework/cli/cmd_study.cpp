// External evaluation of a study: `varbo study create`, `suggest`, `observe`, `fail`, `abandon`.
// Every command opens the study file, does one transaction and exits, so several workers may share a study.
#include <fmt/format.h>
#include <signal.h>

#include <map>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <optional>
#include <set>
#include <nlohmann/json.hpp>

#include "cli_parse.hpp"
#include "commands.hpp"
#include "varbo/csv.hpp"
#include "varbo/errors.hpp"
#include "varbo/log.hpp"
#include "varbo/named_values.hpp"
#include "varbo/run_lock.hpp"
#include "varbo/run_liveness.hpp"
#include "varbo/store.hpp"
#include "varbo/study_api.hpp"
#include "varbo/text.hpp"

namespace varbo::cli {

namespace {
/// `--component name=value` words; a name given twice is refused (one of the values would be dropped silently).
Components parse_components(const std::vector<std::string>& words) {
  Components comps;
  for (const auto& w : words) {
    auto c = parse_component(w);
    for (const auto& [name, value] : comps)
      if (name == c.first)
        throw InputError(fmt::format("--component {}: given twice ({} and {}); each component once; nothing written",
                                     name, exact(value), exact(c.second)));
    comps.push_back(std::move(c));
  }
  return comps;
}
/// θ of `--param name=value` words: every parameter of the study named once (a fixed one may be left out).
Vec theta_from_params(const Study& s, const std::vector<std::string>& words) {
  const std::vector<std::string>& names = s.domain().names;
  const SearchSpace space = s.space() ? *s.space() : SearchSpace::from_box(s.domain().box, names);
  std::vector<std::pair<std::string, std::string>> values;
  for (const auto& w : words) {
    // At the '=' after a parameter's whole name when one matches: a name may hold '=' itself (`k=d`, as `varbo
    // suggest` prints it: "k=d=0.81"), which the first '=' cut in two (red team, session 29).
    auto eq = w.find('=');
    for (const auto& n : names)  // a match means w holds '=', so eq is set
      if (w.size() > n.size() && w.compare(0, n.size(), n) == 0 && w[n.size()] == '=') eq = std::max(eq, n.size());
    if (eq == std::string::npos || eq == 0)
      throw InputError(fmt::format("--param '{}': expected name=value, e.g. --param {}=...", w, names.front()));
    values.emplace_back(w.substr(0, eq), w.substr(eq + 1));
  }
  return theta_of_named(space, values, "--param");
}

/// θ of `observe/fail STUDY new`: --theta v1,v2,... or --param name=value ..., exactly one of them.
Vec manual_theta(const Study& s, const std::string& theta, const std::vector<std::string>& params, const char* verb) {
  if (!theta.empty() && !params.empty())
    throw InputError(fmt::format("{} new: give either --theta or --param, not both", verb));
  if (!params.empty()) return theta_from_params(s, params);
  if (theta.empty())
    throw InputError(fmt::format("{} new: give the evaluated point with --theta v1,v2,... or --param name=value ...",
                                 verb));
  std::vector<double> v;
  for (std::size_t start = 0; start <= theta.size();) {
    const std::size_t comma = std::min(theta.find(',', start), theta.size());
    v.push_back(parse_number(theta.substr(start, comma - start), "--theta"));
    start = comma + 1;
  }
  return Eigen::Map<const Vec>(v.data(), static_cast<Index>(v.size()));
}
}  // namespace

Runner add_study(CLI::App& app) {
  auto* cmd = app.add_subcommand("study", "Manage study files (durable ask/tell studies)");
  auto* create = cmd->add_subcommand("create", "Create STUDY.db from a study configuration (task: gives the domain)");
  cmd->require_subcommand(1);
  struct Args {
    std::string store, config;
  };
  auto a = std::make_shared<Args>();
  create->add_option("store", a->store, "the study to create: a file (SQLite), or postgresql://user@host/db?study=NAME")->required();
  create->add_option("config", a->config, "study configuration (YAML)")->required();
  auto* verify = cmd->add_subcommand("verify", "Replay the whole study and report the first divergence from the stored "
                                               "trials and saved algorithm states (exit 1 if any)");
  verify->add_option("store", a->store, "study file, or postgresql://...?study=NAME URL")->required();
  return [a, verify]() {
    if (verify->parsed()) {
      Study s = Study::open(a->store);
      const VerifyReport r = s.verify();
      if (!r.divergence.empty()) {
        std::printf("%s: DIVERGES after replaying %ld trial(s): %s\n", terminal_line(s.store().location()).c_str(),
                    static_cast<long>(r.replayed),
                    r.divergence.c_str());
        return 1;
      }
      std::printf("%s: ok: %ld finished trial(s) replayed, every serial trial reproduced, %ld saved algorithm "
                  "state(s) equal to the replay\n",
                  terminal_line(s.store().location()).c_str(), static_cast<long>(r.replayed), static_cast<long>(r.states_compared));
      return 0;
    }
    Study s = Study::create(a->store, a->config);
    // The store's location: a PostgreSQL URL's password is shown as *** (cron logs keep stdout).
    std::printf("created %s: task %s, algorithm %s, budget %ld, %ld parameters (%s)\n", terminal_line(s.store().location()).c_str(),
                s.config().task.info->name.c_str(), s.config().algorithm.info->name.c_str(),
                static_cast<long>(s.config().budget), static_cast<long>(s.domain().box.dim()),
                terminal_line(join(s.domain().names)).c_str());
    return 0;
  };
}

Runner add_suggest(CLI::App& app) {
  auto* cmd = app.add_subcommand("suggest", "Suggest trials (marked pending) and print their ids and θ in user units");
  struct Args {
    std::string store, worker;
    long long batch = 1;
    bool json = false;
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("store", a->store, "study file, or postgresql://...?study=NAME URL")->required();
  cmd->add_option("--batch", a->batch, "number of distinct trials to suggest (they account for pending ones)")
      ->check(integer_in(1, 100000));
  cmd->add_flag("--json", a->json, "print JSON: [{\"id\": 3, \"theta\": [...], \"names\": [...], \"phase\": ...}]");
  cmd->add_option("--worker", a->worker, "name recorded for these trials (default host:pid)");
  return [a]() {
    std::optional<Study> opened = Study::open(a->store);
    Study& s = *opened;
    if (!a->worker.empty()) s.set_worker(a->worker);
    const auto trials = s.ask(a->batch);
    if (trials.empty()) {
      Index finished = 0, pending = 0;
      for (const auto& t : s.trials()) {
        finished += t.finished() ? 1 : 0;
        pending += t.state == TrialState::Pending ? 1 : 0;
      }
      // Exit 4, not 2: a script's loop (`while t=$(varbo suggest S); do …; done`) ends here as planned, and must be
      // able to tell that from an error (an unreachable database, a broken study), which it should report or retry.
      std::fprintf(stderr,
                   "varbo: %s: nothing to suggest: the budget of %lld trials is used (%lld finished, %lld pending) or "
                   "the algorithm is done\n",
                   printable(s.store().location()).c_str(), static_cast<long long>(s.config().budget),
                   static_cast<long long>(finished), static_cast<long long>(pending));
      return 4;
    }
    if (static_cast<long long>(trials.size()) < a->batch) {  // on stderr: stdout stays the trials (or the JSON)
      Index taken = 0;  // finished or pending: what the budget holds now
      for (const auto& t : s.trials()) taken += t.finished() || t.state == TrialState::Pending ? 1 : 0;
      if (taken >= s.config().budget)
        std::fprintf(stderr, "varbo: %zu of the %lld trials asked: the budget of %lld has no more room\n",
                     trials.size(), a->batch, static_cast<long long>(s.config().budget));
      else
        std::fprintf(stderr, "varbo: %zu of the %lld trials asked: the algorithm gave no more points (%lld of the "
                     "budget of %lld left)\n",
                     trials.size(), a->batch, static_cast<long long>(s.config().budget - taken),
                     static_cast<long long>(s.config().budget));
    }
    const auto& names = s.domain().names;
    if (a->json) {
      nlohmann::json out = nlohmann::json::array();
      for (const auto& t : trials) {
        out.push_back({{"id", t.id},
                       {"theta", std::vector<double>(t.theta.data(), t.theta.data() + t.theta.size())},
                       {"names", names},
                       {"phase", t.phase}});
        if (s.space()) out.back()["params"] = nlohmann::json::parse(s.space()->params(t.theta).to_json());
      }
      std::printf("%s\n", out.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
    } else {
      for (const auto& t : trials) {
        std::string line = fmt::format("trial {}", t.id);
        for (Index i = 0; i < t.theta.size(); ++i)
          line += fmt::format(" {}={}", terminal_line(names[static_cast<std::size_t>(i)]),
                              s.space() ? terminal_line(s.space()->format_value(static_cast<std::size_t>(i), t.theta[i]))
                                        : exact(t.theta[i]));
        std::printf("%s  (%s)\n", line.c_str(), terminal_line(t.phase).c_str());
      }
    }
    if (std::fflush(stdout) != 0 || std::ferror(stdout)) {
      // Nobody received θ (`> /dev/full`, a closed pipe): the trials would stay pending until abandoned by hand,
      // with their points held back from every other suggestion (red team, session 27). main() reports the error.
      const int err = errno;
      std::set<std::int64_t> asked;
      for (const auto& t : trials) asked.insert(t.id);
      const auto ids = s.abandon_where([&](const TrialRecord& p) { return asked.count(p.id) > 0; },
                                       "the suggestion could not be printed");
      std::fprintf(stderr, "varbo: %s: standard output could not be written; the %zu trial(s) suggested were abandoned\n",
                   printable(s.store().location()).c_str(), ids.size());
      errno = err;
    }
    opened.reset();  // closing the store: SQLite checkpoints its write-ahead log into the file
    log_debug("suggest: store closed: process CPU {:.2f} ms", 1e3 * static_cast<double>(std::clock()) / CLOCKS_PER_SEC);
    return 0;
  };
}

Runner add_observe(CLI::App& app) {
  auto* cmd = app.add_subcommand("observe", "Record the cost of a pending trial");
  struct Args {
    std::string store, id, cost;
    std::vector<std::string> components;
    std::string theta;
    std::vector<std::string> params;
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("store", a->store, "study file, or postgresql://...?study=NAME URL")->required();
  cmd->add_option("id", a->id, "trial id printed by `varbo suggest`, or 'new' with --theta")->required();
  cmd->add_option("cost", a->cost, "the observed cost (a finite number)")->required();
  cmd->add_option("--component", a->components, "a named cost component, name=value (repeatable)");
  cmd->add_option("--theta", a->theta, "with ID 'new': the θ evaluated, user units, comma-separated (e.g. 0.5,2)");
  cmd->add_option("--param", a->params,
                  "with ID 'new': one parameter of the θ evaluated, name=value (a label for a category; repeatable)");
  return [a]() {
    if (a->id == "new") {
      const double cost = parse_number(a->cost, "COST");
      const Components comps = parse_components(a->components);
      Study s = Study::open(a->store);
      const auto id = s.tell_point(manual_theta(s, a->theta, a->params, "observe"), cost, comps);
      std::printf("trial %lld: cost %s recorded at the given %s\n", static_cast<long long>(id), exact(cost).c_str(),
                  a->params.empty() ? "θ" : "parameters");
      return 0;
    }
    if (!a->theta.empty()) throw InputError("observe: --theta goes with ID 'new' (a point no suggestion produced)");
    if (!a->params.empty()) throw InputError("observe: --param goes with ID 'new' (a point no suggestion produced)");
    const std::int64_t id = parse_id(a->id);
    const double cost = parse_number(a->cost, "COST");
    const Components comps = parse_components(a->components);
    Study s = Study::open(a->store);
    s.tell(id, cost, comps);
    std::printf("trial %lld: cost %s recorded\n", static_cast<long long>(id), exact(cost).c_str());
    return 0;
  };
}

Runner add_fail(CLI::App& app) {
  auto* cmd = app.add_subcommand("fail", "Record that a pending trial failed (it counts against the budget), or that "
                                         "a θ you tried yourself failed (ID 'new' with --theta or --param)");
  struct Args {
    std::string store, id, reason = "failed", theta;
    std::vector<std::string> params;
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("store", a->store, "study file, or postgresql://...?study=NAME URL")->required();
  cmd->add_option("id", a->id, "trial id, or 'new' with --theta or --param")->required();
  cmd->add_option("--reason", a->reason, "why it failed (stored with the trial)");
  cmd->add_option("--theta", a->theta, "with ID 'new': the θ that failed, user units, comma-separated (e.g. 0.5,2)");
  cmd->add_option("--param", a->params,
                  "with ID 'new': one parameter of the θ that failed, name=value (a label for a category; repeatable)");
  return [a]() {
    // A θ tried by hand that made the robot fall: bo's failure model should learn of it as of a suggested one
    // (docs/failures.md); before, only `observe new` existed and the failure could not be recorded.
    if (a->id == "new") {
      Study s = Study::open(a->store);
      const auto id = s.fail_point(manual_theta(s, a->theta, a->params, "fail"), a->reason);
      std::printf("trial %lld: failed (%s), recorded at the given %s\n", static_cast<long long>(id),
                  a->reason.c_str(), a->params.empty() ? "θ" : "parameters");
      return 0;
    }
    if (!a->theta.empty() || !a->params.empty())
      throw InputError("fail: --theta and --param go with ID 'new' (a point no suggestion produced)");
    const std::int64_t id = parse_id(a->id);
    Study s = Study::open(a->store);
    s.fail(id, a->reason);
    std::printf("trial %lld: failed (%s)\n", static_cast<long long>(id), printable(a->reason).c_str());
    return 0;
  };
}

namespace {
/// Whether a `varbo run` holds the run lock of the study at `url` (its session's advisory lock); a server that
/// cannot be asked counts as holding it (nothing is abandoned on a guess).
bool database_run_is_live(const std::string& url) {
  try {
    DatabaseRunLock::acquire(url);  // released at once
    return false;
  } catch (const InputError&) {
    return true;
  }
}
}  // namespace

/// How long a worker stays alive without a heartbeat, judged by hand: the study's heartbeat_timeout, or 60 s when it
/// is 0 ("never abandon on its own"), which judged every worker ever seen live (red team, session 29); with 0 a worker
/// beats every 10 s (cmd_worker.cpp).
static double liveness_window(const Study& s) {
  return s.config().heartbeat_timeout > 0 ? s.config().heartbeat_timeout : 60.0;
}

bool run_is_live(const std::string& location) {
  return is_database_url(location) ? database_run_is_live(location) : RunLock::held(RunLock::lock_file_of(location));
}

Runner add_abandon(CLI::App& app) {
  auto* cmd = app.add_subcommand("abandon", "Abandon pending trials (their points may be suggested again): those "
                                            "named by --id, else every pending trial whose worker is not alive");
  struct Args {
    std::string store;
    std::string older_than = "0";
    std::vector<std::string> ids;
    bool include_live = false;
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("store", a->store, "study file, or postgresql://...?study=NAME URL")->required();
  cmd->add_option("--id", a->ids, "abandon this pending trial (repeatable); without it: every pending trial that "
                                  "passes the other options");
  cmd->add_option("--older-than", a->older_than, "only trials suggested more than this many seconds ago (0 = all)");
  cmd->add_flag("--include-live", a->include_live,
                "also trials held by a worker whose heartbeat is fresh (within the study's heartbeat_timeout): "
                "by default they are spared, since that worker is still running them");
  return [a]() {
    const double older_than = parse_number(a->older_than, "--older-than");
    if (!std::isfinite(older_than) || older_than < 0)
      throw InputError(fmt::format("--older-than: expected a finite number of seconds ≥ 0, got '{}'; nothing written",
                                   a->older_than));
    std::vector<std::int64_t> wanted;
    for (const auto& text : a->ids) wanted.push_back(parse_id(text));
    Study s = Study::open(a->store);
    // Named trials must be pending: abandoning a finished one would be a silent no-op the user took for done.
    for (const auto id : wanted) {
      const auto t = s.store().trial(id);
      if (!t) throw InputError(fmt::format("{}: no trial {}; nothing written", s.store().location(), id));
      if (t->state != TrialState::Pending)
        throw InputError(fmt::format("{}: trial {} is {}, not pending; nothing written", s.store().location(), id,
                                     state_name(t->state)));
    }
    // A worker is alive while its heartbeat is fresher than the study's heartbeat_timeout (docs/studies.md,
    // "Workers"). Before, `varbo abandon` took every pending trial, a live worker's included, which then ran twice.
    const double now = unix_time(), window = liveness_window(s);
    std::map<std::string, double> beat;
    for (const auto& w : s.store().workers())
      if (w.state == "running") beat[w.id] = w.heartbeat_at;
    // A `varbo run` has no heartbeat row: it holds the study's run lock while it lives, and records its worker id
    // (`run_worker/ID`). Its in-flight trial was abandoned and, with a worker helping, ran twice on the rig (red
    // team, session 28).
    const std::string location = a->store;
    const bool run_live = run_is_live(location);
    std::vector<std::string> spared;
    // A worker of this host whose process is gone is dead whatever its last heartbeat: a SIGKILLed worker's
    // trial was spared as "held by a live worker" for a whole heartbeat_timeout (red team, session 34).
    auto live = [&](const TrialRecord& t) {
      if (t.worker.empty()) return false;
      // The lock's session ends with a server restart while the run lives: its heartbeat then says so
      // (run_liveness.hpp; re-audit, session 49).
      if (s.store().meta("run_worker/" + t.worker) &&
          (run_live || (is_database_url(location) && run_heartbeat_recent(s.store(), t.worker, window))))
        return true;
      const auto it = beat.find(t.worker);
      return it != beat.end() && now - it->second < window && !worker_process_gone(t.worker);
    };
    auto holder = [&](const TrialRecord& t) {
      return beat.count(t.worker) ? fmt::format("{} (worker {}, heartbeat {:.0f} s ago)", t.id, printable(t.worker),
                                                now - beat[t.worker])
                                  : fmt::format("{} (the live `varbo run` {})", t.id, printable(t.worker));
    };
    // A trial named by --id is what the user asked for: sparing it in silence and exiting 0 told a script it was
    // abandoned (red team, session 28).
    if (!a->include_live)
      for (const auto id : wanted)
        if (const auto t = s.store().trial(id); t && live(*t))
          throw InputError(fmt::format("{}: trial {} is held by a live worker: {}; --include-live abandons it anyway "
                                       "(its point may then be suggested again; a late result is still recorded); "
                                       "nothing written",
                                       s.store().location(), id, holder(*t)));
    // The same for a named trial that --older-than would spare: "abandoned 0 trial(s)", exit 0 (audit, session 47).
    if (older_than > 0)
      for (const auto id : wanted)
        if (const auto t = s.store().trial(id); t && now - t->created_at <= older_than)
          throw InputError(fmt::format("{}: trial {} was suggested {:.0f} s ago, not more than --older-than {}; drop "
                                       "--older-than to abandon it; nothing written",
                                       s.store().location(), id, std::max(0.0, now - t->created_at), a->older_than));
    const auto ids = s.abandon_where(
        [&](const TrialRecord& t) {
          if (!wanted.empty() && std::find(wanted.begin(), wanted.end(), t.id) == wanted.end()) return false;
          if (older_than > 0 && now - t.created_at <= older_than) return false;
          if (!a->include_live && live(t)) {
            spared.push_back(holder(t));
            return false;
          }
          return true;
        },
        older_than > 0 ? fmt::format("abandoned (pending longer than {} s)", older_than) : std::string("abandoned"));
    std::vector<std::string> t;
    for (auto id : ids) t.push_back(std::to_string(id));
    std::printf("abandoned %zu trial(s)%s%s\n", ids.size(), ids.empty() ? "" : ": ", join(t).c_str());
    if (!spared.empty())
      std::printf("spared %zu trial(s) held by a live worker: %s (--include-live abandons them too)\n", spared.size(),
                  join(spared).c_str());
    return 0;
  };
}

Runner add_retract(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "retract", "Take back failed trials that were the rig's fault, not their θ's (an E-stop, a cable, a wrong "
                 "folder): the algorithm is rebuilt without them, so bo's failure model forgets them");
  struct Args {
    std::string store;
    std::vector<std::string> ids;
    std::string reason = "the rig, not θ, failed";
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("store", a->store, "study file, or postgresql://...?study=NAME URL")->required();
  cmd->add_option("--id", a->ids, "a failed trial to take back (repeatable)")->required();
  cmd->add_option("--reason", a->reason, "why, kept with the trial")->capture_default_str();
  return [a]() {
    std::vector<std::int64_t> wanted;
    for (const auto& text : a->ids) wanted.push_back(parse_id(text));
    Study s = Study::open(a->store);
    // Refused while a live run or worker holds an algorithm that was told these failures (Study::retract_failures).
    const auto ids = s.retract_failures(wanted, a->reason);
    std::vector<std::string> t;
    for (auto id : ids) t.push_back(std::to_string(id));
    std::printf("took back %zu failed trial(s): %s; the algorithm no longer learns from them (they stay in the "
                "tables, and count against the budget: `varbo run --resume DIR --budget N` adds trials)\n",
                ids.size(), join(t).c_str());
    return 0;
  };
}

}  // namespace varbo::cli
