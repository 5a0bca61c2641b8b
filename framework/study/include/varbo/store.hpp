#pragma once
// Durable storage of a study: its configuration, every trial and the model snapshots. The StudyStore
// interface is all the rest of varbo sees, so another backend (a server database, ...) can be added
// without touching algorithms; the default is one SQLite file (store_sqlite.cpp).
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "varbo/algorithm.hpp"
#include "varbo/errors.hpp"
#include "varbo/task.hpp"

namespace varbo {

/// pending: handed out, no result yet; complete: cost observed; failed: the trial ran and failed (it counts
/// against the budget and the algorithm is told ok = false); abandoned: its worker died, the result will never
/// come (the trial is ignored, its point may be suggested again).
enum class TrialState { Pending, Complete, Failed, Abandoned };
std::string state_name(TrialState state);
TrialState state_from_name(const std::string& name);  ///< throws InputError

struct TrialRecord {
  std::int64_t id = -1;           ///< assigned by the store: 0, 1, 2, ... in order of suggestion
  TrialState state = TrialState::Pending;
  std::string phase;              ///< the algorithm's label ("initial", "ei", ...)
  Vec x;                          ///< unit cube, exactly as the algorithm suggested it
  Vec theta;                      ///< user units
  double cost = std::numeric_limits<double>::quiet_NaN();
  Components components;
  double noiseless_cost = std::numeric_limits<double>::quiet_NaN();
  std::string error;              ///< reason of a failed or abandoned trial
  std::string worker;             ///< who asked ("host:pid" or a name given by the caller)
  double created_at = 0;          ///< unix seconds
  double finished_at = 0;         ///< unix seconds, 0 while pending
  /// Order in which trials finished (complete or failed): 0, 1, 2, ...; -1 while pending or abandoned.
  /// The algorithm is re-told results in this order when a study is rebuilt (study_replay.hpp).
  std::int64_t finish_seq = -1;
  // How the trial was suggested, to know whether a replay must reproduce its point exactly.
  std::int64_t finished_before = 0;  ///< finished trials when it was suggested
  std::int64_t pending_before = 0;   ///< other pending trials when it was suggested
  std::int64_t batch_size = 1;
  std::int64_t batch_index = 0;
  double fit_seconds = 0, acquisition_seconds = 0, evaluation_seconds = 0;

  bool finished() const { return state == TrialState::Complete || state == TrialState::Failed; }
};

/// The reason of a failed trial taken back by `varbo retract` (Study::retract_failures) begins with this.
inline constexpr const char* kRetractedPrefix = "taken back by `varbo retract`";
/// Study meta key: when the last failure was taken back (unix time); algorithm states saved before it hold it.
inline constexpr const char* kRetractedAtKey = "retracted_at";
/// A failed trial taken back: the algorithm is not told it (study_rebuild.cpp).
inline bool retracted(const TrialRecord& t) {
  return t.state == TrialState::Failed && t.error.rfind(kRetractedPrefix, 0) == 0;
}

struct StoredSnapshot {
  std::int64_t after_trials = 0;  ///< finished trials when the snapshot was taken
  ModelSnapshot snapshot;
};

/// The saved state of an algorithm that offers AlgorithmState (varbo/state.hpp): the algorithm after it was
/// told the first `finished` results (in finish order), and, when `outstanding` ≥ 0, asked once more for the
/// trial with that id (a serial ask, nothing pending). A study opens from the state reaching furthest.
struct AlgorithmSnapshot {
  std::int64_t finished = 0;
  std::int64_t outstanding = -1;
  std::string state;
  double created_at = 0;
};

/// A process working on a study (`varbo worker`, or any Study that sends heartbeats), across machines.
struct WorkerRecord {
  std::string id;            ///< host:pid:nonce
  std::string host;
  long pid = 0;
  double started_at = 0;     ///< unix seconds
  double heartbeat_at = 0;   ///< latest sign of life
  std::string state = "running";  ///< running | stopped
};

/// This process lost contact with a store's server: a StoreConnectionError was raised (every connection breaks when
/// the server restarts, so the first call after an outage raises one), or a heartbeat could not be recorded.
/// Whoever judges another process dead by its silence counts only the time since then: the other process could
/// not reach the server either. Before, the first worker back after an outage longer than heartbeat_timeout
/// abandoned every live worker's trial and ran its θ again (red team, session 49).
void note_store_unreachable() noexcept;
/// Seconds (this process's monotonic clock) since note_store_unreachable() was last called; infinity when never.
double seconds_since_store_unreachable() noexcept;

/// The store's server could not be reached or the connection was lost (PostgreSQL); the operation wrote
/// nothing, unless the message says the commit itself was cut ("may or may not have been written"). A process
/// that stays up may retry (`varbo worker` does, with backoff).
class StoreConnectionError : public InputError {
 public:
  explicit StoreConnectionError(const std::string& what) : InputError(what) { note_store_unreachable(); }
  explicit StoreConnectionError(const char* what) : InputError(what) { note_store_unreachable(); }
};

class StudyStore {
 public:
  /// Schema version written into the `meta` table; opening a store with a newer version is an error.
  /// 2: algorithm states (a version-1 store is upgraded when opened).
  static constexpr int kSchemaVersion = 2;

  virtual ~StudyStore();
  /// The file (or URL) of the store, for messages.
  virtual const std::string& location() const = 0;

  /// Runs `body` as one atomic, exclusive transaction (SQLite: BEGIN IMMEDIATE ... COMMIT, retried when the
  /// store is busy; PostgreSQL: the study's row locked FOR UPDATE, the whole transaction retried with backoff
  /// when the server reports a serialization failure or deadlock, so `body` must be safe to run again).
  /// An exception inside `body` rolls everything back and is rethrown. Nested calls join the outer
  /// transaction. Reads outside a transaction see a consistent snapshot too.
  virtual void transaction(const std::function<void()>& body) = 0;

  virtual std::optional<std::string> meta(const std::string& key) const = 0;
  virtual void set_meta(const std::string& key, const std::string& value) = 0;

  /// Every trial, by id.
  virtual std::vector<TrialRecord> trials() const = 0;
  virtual std::optional<TrialRecord> trial(std::int64_t id) const = 0;
  /// Finished (complete or failed) trials with finish_seq >= `seq`, in finish order.
  virtual std::vector<TrialRecord> finished_since(std::int64_t seq) const = 0;
  /// Pending trials, by id.
  virtual std::vector<TrialRecord> pending_trials() const = 0;
  /// Inserts a trial (its id is ignored) and returns the id assigned.
  virtual std::int64_t add_trial(const TrialRecord& trial) = 0;
  /// Replaces every field of the trial with this id.
  virtual void update_trial(const TrialRecord& trial) = 0;
  /// 1 + the largest finish_seq (0 when nothing finished).
  virtual std::int64_t next_finish_seq() const = 0;

  virtual void add_snapshot(const StoredSnapshot& snapshot) = 0;
  virtual std::vector<StoredSnapshot> snapshots() const = 0;

  /// Saves an algorithm state and drops states more than two results older (only the latest are used).
  virtual void add_algorithm_state(const AlgorithmSnapshot& snapshot) = 0;
  /// The algorithm states kept, newest first.
  virtual std::vector<AlgorithmSnapshot> algorithm_states() const = 0;

  /// Inserts or replaces the worker's row.
  virtual void put_worker(const WorkerRecord& worker) = 0;
  virtual std::vector<WorkerRecord> workers() const = 0;

  /// Seconds since the store's server started (infinity: no server, SQLite). No process could beat a heartbeat
  /// while the server was down, so nobody's silence is judged longer than this: a `varbo suggest` run just after
  /// a restart found every worker's heartbeat as old as the outage and abandoned their live trials (red team,
  /// session 49).
  virtual double server_uptime() const { return std::numeric_limits<double>::infinity(); }
  /// When the server started, by its own clock (unix seconds), to tell whether it restarted since a value read
  /// earlier; nullopt without a server (SQLite).
  virtual std::optional<double> server_started_at() const { return std::nullopt; }
};

/// Creates a new SQLite store at `path` holding the `meta` entries; an existing file is an InputError. The
/// file appears complete or not at all.
std::unique_ptr<StudyStore> create_sqlite_store(const std::string& path,
                                                const std::vector<std::pair<std::string, std::string>>& meta = {});
/// Opens an existing SQLite store; a missing file, a file that is not a varbo store, or a store written by a
/// newer varbo (schema version) is an InputError naming the file.
std::unique_ptr<StudyStore> open_sqlite_store(const std::string& path);

/// PostgreSQL: one database holds any number of studies, each addressed by a URL naming the study,
/// `postgresql://user@host[:port]/db?study=NAME` or over a unix socket `postgresql:///db?host=/run/postgresql&study=NAME`
/// (any other libpq parameter may follow; docs/studies.md, "Addresses"). create_postgres_store makes the tables
/// when the database has none; an existing study of that name is an InputError. Every failure (server unreachable,
/// authentication, no such study, a newer store version, a connection lost mid-transaction) is an InputError
/// naming the study and the cause; a failed transaction writes nothing.
std::unique_ptr<StudyStore> create_postgres_store(const std::string& url,
                                                  const std::vector<std::pair<std::string, std::string>>& meta = {});
std::unique_ptr<StudyStore> open_postgres_store(const std::string& url);

/// A study address is a file path (SQLite) or a postgresql:// (or postgres://) URL. The one place that picks the
/// backend: every command and varbo::Study go through these.
bool is_database_url(const std::string& address);
std::unique_ptr<StudyStore> create_store(const std::string& address,
                                         const std::vector<std::pair<std::string, std::string>>& meta = {});
std::unique_ptr<StudyStore> open_store(const std::string& address);
/// Whether a study exists at the address (a file; a study of that name in the database). Connection errors
/// are an InputError, never "false".
bool store_exists(const std::string& address);

/// Meta keys every store holds.
namespace store_key {
inline constexpr const char* kConfig = "config";          ///< resolved YAML of the study
inline constexpr const char* kIdentity = "identity";      ///< what must match to continue the study
inline constexpr const char* kPluginPaths = "plugin_paths";///< extra plugin paths, one per line
inline constexpr const char* kOutput = "output";          ///< run folder of `varbo run`, if any
inline constexpr const char* kDomain = "domain";          ///< the task's parameters and bounds at creation
}  // namespace store_key

/// The host part of worker names: $VARBO_HOST_ID when set (e.g. to tell apart containers that share a host
/// name), else the host name.
std::string host_id();
/// "host:pid" of this process (host from host_id()).
std::string default_worker_name();
/// "host:pid:nonce" (16 random hex digits): a worker id unique across machines and pid reuse. `host` must
/// hold no ':' (InputError); empty: host_id().
std::string new_worker_id(const std::string& host = "");
/// The host and pid of a worker name "host:pid" or "host:pid:nonce"; pid 0 when the name has another form.
std::pair<std::string, long> worker_host_pid(const std::string& worker);
/// Whether `worker` names a process of this host (host_id()) that no longer exists (ESRCH: EPERM is another user's
/// live process). A SIGKILLed worker's heartbeat stays fresh for a while; its process is known gone at once.
bool worker_process_gone(const std::string& worker);
/// Seconds since the epoch.
double unix_time();

}  // namespace varbo
