#include "varbo/run_liveness.hpp"

#include <algorithm>
#include <limits>
#include <optional>

#include "varbo/log.hpp"
#include "varbo/csv.hpp"

namespace varbo {

std::string run_heartbeat_key(const std::string& run_worker) { return "run_heartbeat/" + run_worker; }

std::unique_ptr<BackgroundTicker> start_run_heartbeats(const std::string& store_path, const std::string& run_worker,
                                                       double interval) {
  auto store = std::make_shared<std::unique_ptr<StudyStore>>();
  auto said = std::make_shared<bool>(false);
  // The first beat at once: a worker that sees the lock free just after a restart must find a recent one.
  return std::make_unique<BackgroundTicker>(
      [interval](int k) { return k * interval; },
      [store, said, store_path, run_worker](int) {
        try {
          if (!*store) *store = open_store(store_path);
          (*store)->transaction([&] { (*store)->set_meta(run_heartbeat_key(run_worker), exact(unix_time())); });
          if (std::exchange(*said, false)) log_warn("run {}: heartbeats resumed", run_worker);
        } catch (const Error& e) {
          note_store_unreachable();
          store->reset();  // a broken connection is opened anew at the next beat
          if (!std::exchange(*said, true))
            log_warn("run {}: heartbeat not recorded: {}; trying again at every beat", run_worker, e.what());
        }
        return true;
      });
}

std::string run_lock_server_key(const std::string& run_worker) { return "run_lock_server/" + run_worker; }

void note_run_lock_taken(StudyStore& store, const std::string& run_worker) {
  if (const auto started = store.server_started_at())
    store.transaction([&] { store.set_meta(run_lock_server_key(run_worker), exact(*started)); });
}

bool run_lock_survives(const StudyStore& store, const std::string& run_worker) {
  const std::optional<std::string> noted = store.meta(run_lock_server_key(run_worker));
  const std::optional<double> started = noted ? store.server_started_at() : std::nullopt;
  return started && *noted == exact(*started);
}

bool run_heartbeat_recent(const StudyStore& store, const std::string& run_worker, double window) {
  // A lock that no restart has freed is the run's whole story: free, the run is gone (a SIGKILLed run resumed at
  // once, without waiting out its last heartbeats).
  if (run_lock_survives(store, run_worker)) return false;
  const std::optional<std::string> value = store.meta(run_heartbeat_key(run_worker));
  if (!value) return false;
  double at = 0;
  try {
    at = std::stod(*value);
  } catch (const std::exception&) {
    return false;
  }
  return std::min(unix_time() - at, store.server_uptime()) < window;
}

bool live_run_holds_a_trial(const StudyStore& store, double window) {
  for (const auto& t : store.pending_trials())
    if (!t.worker.empty() && store.meta("run_worker/" + t.worker) && run_heartbeat_recent(store, t.worker, window))
      return true;
  return false;
}

double command_stop_seconds(const ResolvedComponent& task) {
  if (!task.info || task.info->name != "external") return 0;
  const double grace = task.options.declared("grace") && task.options.is_set("grace") ? task.options.real("grace") : 0.2;
  return std::max(0.0, std::min(grace, 1e6)) + 1.0;
}

double RunSilence::seconds(const StudyStore& store, const std::string& run_worker) {
  const std::optional<std::string> value = store.meta(run_heartbeat_key(run_worker));
  if (!value || run_lock_survives(store, run_worker)) return std::numeric_limits<double>::infinity();
  const auto now = std::chrono::steady_clock::now();
  auto it = seen_.find(run_worker);
  // First read, or it beat since: judged afresh, from 0 — the value is the run host's clock, which may differ
  // from ours, so a run is silent only once this process has seen its heartbeat unchanged for the whole window.
  if (it == seen_.end() || it->second.value != *value)
    it = seen_.insert_or_assign(run_worker, Seen{*value, now}).first;
  const double silence =
      std::chrono::duration<double>(now - it->second.first_read).count();
  return std::min({silence, seconds_since_store_unreachable(), store.server_uptime()});
}

}  // namespace varbo
