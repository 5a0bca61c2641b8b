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

double RunSilence::seconds(const StudyStore& store, const std::string& run_worker) {
  const std::optional<std::string> value = store.meta(run_heartbeat_key(run_worker));
  if (!value) return std::numeric_limits<double>::infinity();
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
