// The state behind varbo::Study (study_api.hpp): the study's configuration, task, space and store, and the live
// algorithm with what it has been told. Private to libvarbo_study; its methods are defined by concern:
// study_impl.cpp (building the study, workers' liveness, retries), study_rebuild.cpp (the algorithm rebuilt from
// saved states plus a replay of the rest), study_plugins.cpp (the plugins a process's studies share).
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "varbo/text.hpp"
#include "varbo/loader.hpp"
#include "varbo/registry.hpp"
#include "varbo/store.hpp"
#include "varbo/study_api.hpp"

namespace varbo {

namespace study_detail {

/// Unit-cube coordinates: a replay must give the same point.
constexpr double kReplayTolerance = 1e-12;

/// What the algorithm is told about a finished trial.
Observation observation_of(const TrialRecord& t);

/// The process's CPU time so far (all threads) at a step of opening a study or asking it, in the --verbose log:
/// what a short `varbo suggest` process spends where (docs/studies.md, "Cost of varbo suggest").
void log_cpu(const char* step);

/// A YAML node as text (the stored configuration, the study's identity).
std::string emit(const YAML::Node& n);

/// `varbo run --resume` with a later varbo: the stored configuration, re-resolved with the plugins loaded now
/// (`config`), may name settings it did not (an option added since, whose default now applies). Then say so, with
/// the first difference, and record the configuration as resolved now, so the study continues with these settings
/// and they are written down from here on; trials and states are untouched. False when nothing differed.
/// Whether an algorithm's recommendation (unit cube / encoding) has the study's dimension and finite coordinates;
/// a third-party algorithm's mistake is said (when `say`) and the point dropped, never printed as θ.
bool usable_recommendation(const Vec& r, Index dim, const std::string& algorithm, bool say);

/// θ in user units of an algorithm's recommendation `r` (unit cube / encoding): the stored θ of the complete trial
/// at that point when there is one (the evaluated-point rules), else `r` decoded. Decoding gave 3.0999999999999996
/// for a trial at 3.1 and 0.0010000000000000002 for lr = 0.001 (red team, session 30).
Vec recommended_theta(const Vec& r, const std::vector<TrialRecord>& trials, const SearchSpace* space, const Box& box);

bool adopt_current_resolution(const std::string& store_path, const StudyConfig& config, const Registry& registry);

/// Two emitted identities that describe the same study: equal texts, or equal once every list and map is in
/// block style (the source's flow style of `parameters:` is kept in a stored identity).
bool same_identity(const std::string& stored, const std::string& now);

/// The first line where two emitted YAML texts differ, with its key path: "at task.upper: stored 'a' vs now 'b'".
std::string first_difference(const std::string& stored, const std::string& now);
/// A failed trial's reason as the study keeps it, whichever path records it (a task's evaluation in a run, `fail`,
/// `fail_point`): printable, at most 2 KiB at each end (a 50 MB answer, a NUL byte from Python).
inline std::string stored_reason(const std::string& reason) { return abbreviate(printable(reason), 2048); }

/// parse_study on the configuration stored with the study at `store_path`. A component no loaded plugin provides
/// gets a hint: a study created by a process that loaded a plugin itself (Python's load_plugin, a C++ host's
/// loader) stores no path to it, and opening it elsewhere said only "unknown acquisition 'x'. Known: ..." (red
/// team, session 31).
StudyConfig parse_stored_study(const ConfigNode& root, const Registry& registry, const std::string& store_path);

}  // namespace study_detail

struct Study::Impl {
  std::unique_ptr<Registry> own_registry;
  std::unique_ptr<PluginLoader> loader;
  const Registry* registry = nullptr;
  StudyConfig config;
  std::unique_ptr<Task> task;
  Domain domain;
  SharedSpace space;  ///< typed parameters and constraints (docs/search_space.md); null for a plain box
  std::optional<Vec> initial_unit;
  std::optional<Vec> initial_theta;  ///< the initial point as given (user units): its trial's θ, exactly
  std::unique_ptr<StudyStore> store;
  /// The study file this object writes to (none for a URL). SQLite keeps writing to a deleted or replaced file
  /// through its open descriptor: results told after `rm study.db` vanished in silence (red team, session 27; the
  /// Python wrapper checked it, the C++ class did not). Every writing call first checks the path still names it.
  std::optional<std::pair<std::uint64_t, std::uint64_t>> file_id;  ///< (device, inode) at the open
  std::string file_path;  ///< absolute: a chdir of the host does not move the study
  std::string address;    ///< as opened (a URL with its password: the run lock's probe connects with it)
  /// Whether a `varbo run` holds the study's run lock (a lock file; a session on a database server).
  bool run_is_live() const;
  void note_file();
  void check_file() const;
  std::string worker = default_worker_name();

  // The live algorithm: it has been asked once and told once for each id in told_ids (in that order), plus
  // possibly one more ask(1) whose trial is `outstanding`. Anything else (a batch, pending points) makes it
  // `dirty`: the next use rebuilds it from the store.
  std::unique_ptr<Algorithm> alg;
  std::vector<std::int64_t> told_ids;
  std::optional<std::int64_t> outstanding;
  bool dirty = true;
  bool said_pending_hold_budget = false;  ///< ask's note, once per Study object (a waiting worker polls)
  Index mismatches = 0;
  /// Set while a replay has passed a failed trial taken back (varbo retract): later trials are not the points the
  /// algorithm would ask for now, which is expected, not a mismatch to report.
  bool past_retracted = false;
  /// The study's kRetractedAtKey when this object last rebuilt its algorithm: another process's retraction is
  /// noticed at the next sync (an open Study driving the study went on learning from the failures taken back).
  std::string retracted_seen;
  Index replayed = 0;         ///< trials replayed (ask + tell) since this object was opened
  /// How far the stored states reach (told results, +1 for a state with an outstanding trial): a state is
  /// saved only when the live algorithm is further.
  std::int64_t saved_reach = -1;
  bool save_failure_said = false;  ///< a state that cannot be saved is said once per process, not per result

  // --- the study (study_impl.cpp) ---

  /// Builds the task (for its domain) and checks the initial point, as `varbo run` does.
  void init(const StudyConfig& c, const Registry& reg);
  void init_space();

  /// The point a trial records for the algorithm's suggestion x (unit cube): admissible in the space.
  Vec trial_x(const Vec& x) const {
    const Index d = x.size();
    return space ? space->admissible(x) : Vec(Box::unit(d).clamp(x));
  }
  Vec theta_of(const Vec& x) const {
    // θ0 as written: the encode/decode round trip of a log-scaled 0.001 gave 0.0010000000000000002 (audit,
    // session 47), and a known policy should reach the rig exactly.
    if (initial_unit && initial_theta && x.size() == initial_unit->size() && x == *initial_unit) return *initial_theta;
    return space ? space->decode(x) : from_unit(x, domain.box);
  }
  Index encoded_dim() const { return space ? space->encoded_dim() : domain.box.dim(); }
  Index theta_dim() const { return space ? static_cast<Index>(space->size()) : domain.box.dim(); }
  /// `trials` after checking that every trial's x and θ have the study's sizes: a row edited by hand (a θ of three
  /// values in a 2-parameter study) crashed `varbo status` and ended `--resume` in an internal error.
  std::vector<TrialRecord> checked(std::vector<TrialRecord> trials) const;

  std::unique_ptr<Algorithm> make_algorithm() const;

  /// Pending trials of workers silent for longer than heartbeat_timeout are abandoned (their results will
  /// not come: the worker died, on this machine or another). Trials of processes that never sent a heartbeat
  /// (`varbo suggest`) are left alone. Silence is judged at `asked_at`, when this process asked for the store's
  /// lock, not when it got it: while another process held the lock (a long fit, or one stopped inside its
  /// transaction by Ctrl-Z or SIGSTOP) no heartbeat could be written on SQLite, and judging after the wait
  /// abandoned the trials of live workers (red team, session 25: one θ run three times).
  void abandon_silent_workers(double asked_at);
  /// Per worker: the heartbeat last read, when this process first read it (its monotonic clock) and the silence
  /// the wall clock gave then. A worker's silence is that plus the monotonic time since, while its heartbeat stays
  /// the same: a wall clock stepped forward (NTP on a robot PC without a battery clock) or a resumed laptop made
  /// every live worker look silent, and two workers abandoned each other's trials: one θ ran 4 times (red team,
  /// session 29). A process reading a worker's heartbeat for the first time still judges by the wall clock.
  struct HeartbeatSeen {
    double heartbeat_at;
    std::chrono::steady_clock::time_point first_read;
    double silence_then;
  };
  std::map<std::string, HeartbeatSeen> heartbeats_seen;

  /// Warns (once per study and direction) about a cost beyond ~1e150 or below ~1e-150 in magnitude: the models
  /// square costs. `id` < 0: a point told by hand. Per study, not per process: a second study opened by the same
  /// Python process was never warned (red team, session 25).
  void check_cost_scale(std::int64_t id, double cost);
  bool warned_huge_cost = false;
  bool warned_tiny_cost = false;

  /// With retry_abandoned: new pending trials at the θ of abandoned trials not retried yet (phase "retry"),
  /// at most `q`. The meta key retried/<id> links an abandoned trial to its retry.
  std::vector<TrialRecord> retries(Index q);

  /// The trial `id`, which must be pending (or abandoned: a late result); `verb` names the command refused.
  TrialRecord pending_trial(std::int64_t id, const char* verb) const;

  /// The meta entries a new store at `store_address` is created with: the resolved configuration, its identity,
  /// the plugin paths (stored_plugin_paths.hpp).
  std::vector<std::pair<std::string, std::string>> meta_entries(const std::string& identity,
                                                                const std::string& store_address) const;

  // --- the algorithm rebuilt from saved states and the trials (study_rebuild.cpp) ---

  static std::vector<Observation> observations_of(const std::vector<TrialRecord>& trials, std::size_t n);

  /// The saved state reaching furthest into `finished` (the finished trials in finish order), and its reach
  /// (results it stands for: +1 for a state after an ask whose trial finished next); nullptr if none.
  const AlgorithmSnapshot* best_state(const std::vector<AlgorithmSnapshot>& states,
                                      const std::vector<TrialRecord>& finished, std::int64_t& best_reach) const;

  /// A fresh algorithm, continued from the saved state that reaches furthest into the finished trials when
  /// the algorithm offers AlgorithmState; sync() replays the rest. Returns the finished trials it read (all of
  /// them, in finish order), or nothing when it read none.
  std::optional<std::vector<TrialRecord>> rebuild();

  /// The finished trials from finish_seq told_ids.size() on: taken from `all` (every finished trial, in finish
  /// order, as rebuild() just read them) when given, else read from the store.
  std::vector<TrialRecord> untold(std::optional<std::vector<TrialRecord>>&& all) const;

  /// True when other processes finished more than one trial since this object's algorithm was told and a
  /// saved state covers them: restoring it is cheaper than replaying them (one fit each).
  bool saved_state_is_further() const;

  /// The caller makes sure the live algorithm is in a canonical state: told every finished result in finish
  /// order, nothing pending, and at most one serial ask(1) since (the trial `asked_for`).
  void save_state(std::optional<std::int64_t> asked_for = std::nullopt);
  void say_state_not_saved(std::int64_t told, const std::string& why);
  /// The task's domain, names, cost components and initial point, checked (init(), as plugin code).
  void set_up_task();
  /// The task's parameters and bounds as recorded at creation (store_key::kDomain) and compared at every open.
  std::string domain_text() const;
  /// Throws InputError when the task's domain differs from the one recorded at the study's creation.
  void check_domain_unchanged() const;
  /// Whether save_state(asked_for) would write a state: a transaction is opened for it only then.
  bool state_to_save(std::optional<std::int64_t> asked_for = std::nullopt) const;

  /// ask(1) then tell(t): the step of an uninterrupted serial run that produced t.
  void replay_one(const TrialRecord& t);

  /// Brings the live algorithm in step with the finished trials of the store. finish_seq values are assigned
  /// once, in order, and never change, so only the trials finished since the last sync need reading.
  void sync();
};

// --- the plugins of a process's studies (study_plugins.cpp) ---

/// A Study::Impl with a registry and plugin loader of its own over `paths`. `on_demand`: a study being opened
/// loads only the built-in plugins its configuration looks up (loader.hpp).
std::unique_ptr<Study::Impl> impl_with_plugins(const std::vector<std::string>& paths, bool on_demand = false);

/// The registry shared by every Study::open of this process with the same extra plugin paths (and the same
/// library files there).
const Registry& shared_registry(const std::vector<std::string>& extra);

/// Whether the stored configuration `text` was already found to have the stored `identity` with `registry`
/// (a process checks each study once), and remembering that it has.
bool identity_checked(const Registry& registry, const std::string& text, const std::string& identity);
void remember_identity(const Registry& registry, const std::string& text, const std::string& identity);

}  // namespace varbo
