#pragma once
// varbo::Study — a durable ask/tell study for programs that evaluate trials themselves (a ROS node, a lab
// script). Every call goes through the study store (store.hpp), so several processes may share one study
// and a crash loses nothing that was told.
//
//   auto study = varbo::Study::create("gait.db", "gait.yaml");   // or Study::open("gait.db")
//   for (int i = 0; i < 10; ++i) {
//     auto trial = study.ask().at(0);            // trial.theta in user units, trial.id
//     study.tell(trial.id, run_robot(trial.theta));
//   }
//   auto best = study.best();
//
// How the algorithm is rebuilt: algorithms are deterministic functions of the seed and of the sequence of
// ask/tell calls. An algorithm that offers AlgorithmState (varbo/state.hpp) has its state saved in the store after
// every result and every serial ask; Study re-creates the algorithm from the stored configuration, restores the
// saved state reaching furthest and replays "ask(1), tell(result)" only for results no state covers (an
// algorithm without snapshots: all of them), in the order the results arrived (docs/studies.md). A process that
// keeps its Study open only catches up with what other processes added.
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "varbo/store.hpp"
#include "varbo/study.hpp"

namespace varbo {

/// The point chosen by Study::select.
struct Selection {
  std::int64_t trial_id = -1;
  Vec theta;          ///< user units
  double mean = 0;    ///< E[y] of the refitted surrogate
  double std = 0;     ///< sqrt(V[y]), latent + noise
  double value = 0;   ///< mean + κ·std
};

/// What Study::verify found.
struct VerifyReport {
  Index replayed = 0;         ///< finished trials replayed
  Index states_compared = 0;  ///< saved algorithm states compared with the replayed algorithm
  /// The first divergence (a serial trial whose point the replay does not reproduce, or a saved state that
  /// differs from the replayed one), described; empty when none.
  std::string divergence;
};

/// A study in a store, driven by ask/tell. Threads: one Study object is used by one thread at a time (its calls
/// are not serialized: two threads sharing one crashed or corrupted the store). Several Study objects on one store —
/// in threads or processes — are the supported way to work in parallel; the store serializes them. A moved-from
/// Study throws std::logic_error on use. Study::transaction: when its body throws, the store rolls back and the next
/// call rebuilds the algorithm from the store (results told inside the body are forgotten).
class Study {
 public:
  /// Creates a new study file from a YAML study configuration (the same file `varbo run` takes).
  static Study create(const std::string& store_path, const std::string& config_file);
  /// Creates a new study from YAML text; `name` stands for the file name in messages.
  static Study create_from_yaml(const std::string& store_path, const std::string& yaml,
                                const std::string& name = "<embedded config>");
  /// Opens an existing study file (plugins: the default search path plus the paths stored at creation).
  static Study open(const std::string& store_path);
  /// The same, with components an embedding host adds to the study's registry after the plugins (the Python
  /// module's task `python`, which studies made by varbo.minimize name).
  static Study open(const std::string& store_path, const std::function<void(Registry&)>& add_components);
  /// Opens or creates a study with components from `registry` (which must outlive the Study). An existing
  /// store must hold the same task, algorithm, seed and initial point, else InputError.
  static Study attach(const std::string& store_path, const StudyConfig& config, const Registry& registry);
  /// Builds the task and the algorithm once, touching no file: every configuration error (initial point,
  /// dimension, a component's own checks) surfaces here, before a run folder or store is created.
  static void validate(const StudyConfig& config, const Registry& registry);

  Study(Study&&) noexcept;
  Study& operator=(Study&&) noexcept;
  ~Study();

  /// Up to q new trials (pending until told), distinct from each other and from the pending trials of other
  /// workers. Fewer (possibly none) when the budget is spent or the algorithm has nothing more to suggest.
  std::vector<TrialRecord> ask(Index q = 1);
  /// Records the result of a pending trial. Throws InputError (nothing written) for an unknown or finished id,
  /// a NaN or infinite cost, or a non-finite component.
  void tell(std::int64_t id, double cost, const Components& components = {});
  /// Records the cost of a θ (user units) that no suggestion produced, e.g. a hand-tuned policy, as a new
  /// complete trial (phase "manual"). θ must have the study's dimension and lie in its domain, else InputError
  /// with nothing written. Returns its id.
  std::int64_t tell_point(const Vec& theta, double cost, const Components& components = {});
  /// Records that a θ (user units) no suggestion produced failed, e.g. a hand-tried policy on which the robot
  /// fell, as a new failed trial (phase "manual"): bo's failure model learns of it as of any failed trial.
  /// Checked as tell_point; returns its id.
  std::int64_t fail_point(const Vec& theta, const std::string& reason);
  /// Records a result with everything `varbo run` knows (noiseless cost, timings, failure); returns the trial
  /// as stored.
  TrialRecord record(std::int64_t id, const Evaluation& evaluation, double evaluation_seconds);
  /// Marks a pending trial failed (it counts against the budget; the algorithm is told ok = false).
  void fail(std::int64_t id, const std::string& reason);
  /// Takes failed trials back: the rig, not their θ, failed (an E-stop, a cable, a wrong working folder). They stay
  /// failed trials in the store and its tables (their reason prefixed by kRetractedPrefix) and count against the
  /// budget, but the algorithm is no longer told them: it is rebuilt without them (replayed from before the first
  /// one), so bo's failure model forgets them. Each id must be a failed trial not taken back before; throws
  /// InputError naming the first that is not, nothing written. Returns the ids taken back.
  std::vector<std::int64_t> retract_failures(const std::vector<std::int64_t>& ids, const std::string& reason);
  /// Marks pending trials abandoned: all of them (older_than_seconds = 0) or those created longer ago.
  /// Their points may be suggested again. Returns the ids abandoned.
  std::vector<std::int64_t> abandon(double older_than_seconds = 0, const std::string& reason = "abandoned");
  /// Marks the pending trials for which `which` holds abandoned (e.g. those of a dead worker).
  std::vector<std::int64_t> abandon_where(const std::function<bool(const TrialRecord&)>& which,
                                          const std::string& reason);

  /// Runs `body` as one transaction of the store (nested calls join it): e.g. a result with its model snapshot.
  void transaction(const std::function<void()>& body);
  /// Study-level values kept with the trials (the run folder, per-row figures of `varbo run`).
  std::optional<std::string> meta(const std::string& key) const;
  void set_meta(const std::string& key, const std::string& value);
  /// The model after each fit, as `varbo run` writes it to model.yaml.
  void add_model_snapshot(const StoredSnapshot& snapshot);
  std::vector<StoredSnapshot> model_snapshots() const;

  /// The complete trial with the lowest observed cost.
  std::optional<TrialRecord> best() const;
  /// The θ to deploy (user units): the algorithm's recommendation after every finished trial (bo: its
  /// `recommendation` rule on a model of all of them). Brings the live algorithm up to date first, as ask() does
  /// (a saved state restored, the results since told), so it also answers for a study just opened; nothing when
  /// no trial has finished or the algorithm recommends nothing.
  std::optional<Vec> recommendation();
  /// Among complete trials, the one minimizing E[y] + κ·sqrt(V[y]) under the study's surrogate (the
  /// algorithm's `surrogate:` option, else a default gp) refitted on every complete trial (Kuindersma 2013,
  /// section 3.4: κ > 0 is risk-averse). Evaluated points only: those are the θ that were actually tried.
  std::optional<Selection> select(double kappa = 0.0) const;
  /// The same for several κ on one fit of the model (a κ sweep fitted the model once per κ: 5.6 s each at N = 500;
  /// red team, session 25). One entry per κ, in order.
  std::vector<std::optional<Selection>> select(const std::vector<double>& kappas) const;

  std::vector<TrialRecord> trials() const;
  const StudyConfig& config() const;
  const Domain& domain() const;  ///< names filled in (x1, x2, ... when the task gives none)
  /// Typed parameters and constraints (docs/search_space.md); null for a plain box of reals.
  const SharedSpace& space() const;
  /// The typed, named view of a θ of this study (e.g. a trial's theta): params.real("lr"), .label("solver").
  Params params(const Vec& theta) const;
  /// The store itself, for tests and tools; programs use the methods above.
  StudyStore& store();
  /// The live algorithm, in step with the store after the latest ask(); for snapshots and recommendations.
  const Algorithm* algorithm() const;
  /// The task of the study (used by `varbo run`; external studies never evaluate it).
  Task& task();
  /// Name recorded as the worker of trials asked by this object (default "host:pid").
  void set_worker(const std::string& name);
  /// Records a sign of life of this object's worker (its row in the store's workers table; `state` running or
  /// stopped). A worker that sent heartbeats and then stays silent longer than the study's heartbeat_timeout has
  /// its pending trials abandoned by the next ask() of any process (docs/studies.md, "Workers").
  void heartbeat(const std::string& state = "running");
  /// The components the study was built from (plugins loaded by open/create, or the registry given to attach).
  const Registry& registry() const;
  /// Number of finished trials whose replayed suggestion differed from the stored one (should be 0 for a
  /// serial study: a non-zero count means something is not deterministic).
  Index replay_mismatches() const;
  /// Finished trials replayed (ask + tell, one model fit each for bo) since this object was opened: 0 or 1 per
  /// ask when the algorithm offers snapshots, the whole study otherwise.
  Index replayed() const;
  /// Replays the whole study on a fresh algorithm (ask(1), tell in finish order), checks that every serial
  /// trial's point is reproduced and that every saved algorithm state equals the replayed one; stops at the
  /// first divergence. Writes nothing (`varbo study verify`).
  VerifyReport verify();

  struct Impl;

 private:
  explicit Study(std::unique_ptr<Impl> impl);
  Impl& live() const;  ///< the Impl; std::logic_error on a moved-from Study
  std::int64_t add_manual_trial(const Vec& theta, const Evaluation& evaluation);  ///< tell_point, fail_point
  std::unique_ptr<Impl> impl_;
};

/// The part of a study configuration that must match to continue a stored study.
std::string study_identity(const StudyConfig& config);

}  // namespace varbo
