#pragma once
// Whether a `varbo run` on a database study is alive, as another process (a `varbo worker`) judges it.
//
// The run's one-writer lock on a database study is a session on the server (run_lock.hpp). A server restart ends
// that session while the run lives on, running its trial; a worker that took "lock free" for "run gone" abandoned
// the trial and ran its θ again beside it (red team, session 49: two complete trials of one θ, over the budget).
// So a run also beats a sign of life into the study (meta `run_heartbeat/ID`), and its pending trial is another's
// to take only when the lock is free *and* the run has been silent for the liveness window.
#include <chrono>
#include <map>
#include <memory>
#include <string>

#include "varbo/background_ticker.hpp"
#include "varbo/store.hpp"
#include "varbo/registry.hpp"

namespace varbo {

/// The meta key of run session `run_worker`'s heartbeat (its value: unix seconds).
std::string run_heartbeat_key(const std::string& run_worker);

/// The meta key of the server start time run session `run_worker` saw when it last took its run lock.
std::string run_lock_server_key(const std::string& run_worker);
/// Records, after run session `run_worker` took (or took again) its run lock, which server start it holds it on.
void note_run_lock_taken(StudyStore& store, const std::string& run_worker);
/// Whether the run lock of run session `run_worker` is known to have outlived no server restart: the server has
/// not restarted since the session took it, so a free lock means the run is gone (no heartbeat to wait for).
bool run_lock_survives(const StudyStore& store, const std::string& run_worker);

/// Beats run session `run_worker`'s heartbeat into the study at `store_path` every `interval` seconds, on a
/// connection of its own, until destroyed. A beat that cannot be recorded is tried again at the next one (and
/// counts as lost contact: note_store_unreachable).
std::unique_ptr<BackgroundTicker> start_run_heartbeats(const std::string& store_path, const std::string& run_worker,
                                                       double interval);

/// Whether run session `run_worker`'s heartbeat in `store` is younger than `window` seconds, read once by the
/// wall clock (a process that cannot watch it change: `varbo abandon`, a starting run, a retraction) and never
/// older than the server's uptime. A run host whose clock runs behind ours by more than the window looks silent.
bool run_heartbeat_recent(const StudyStore& store, const std::string& run_worker, double window);

/// Whether a run session whose heartbeat is recent holds one of the study's pending trials: a `varbo run` alive
/// though its lock's server session ended (a restart).
bool live_run_holds_a_trial(const StudyStore& store, double window);

/// Seconds a trial's command may take to stop after the process that ran it is gone: its supervisor sends SIGTERM
/// and SIGKILL `grace` seconds later (an external task's `grace`, 0.2 by default), plus a second. A process judged
/// dead by its silence has its command gone only this much later: a worker that took the trial over at once ran its
/// θ beside the old command still parking the robot (red team, session 49).
double command_stop_seconds(const ResolvedComponent& task);

/// Judges run sessions' silence across calls, on this process's monotonic clock from the first reading of each
/// heartbeat value (the run host's clock may differ from ours: a heartbeat first seen counts as silent for 0 s),
/// and never longer than this process has itself had contact with the server (seconds_since_store_unreachable).
class RunSilence {
 public:
  /// Seconds run session `run_worker` of `store` has been silent (infinity: it never beat, a run of an earlier
  /// version).
  double seconds(const StudyStore& store, const std::string& run_worker);

 private:
  struct Seen {
    std::string value;
    std::chrono::steady_clock::time_point first_read;
  };
  std::map<std::string, Seen> seen_;
};

}  // namespace varbo
