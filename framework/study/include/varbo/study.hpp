#pragma once
// A study: the top-level configuration (task + algorithm + budget + seed + output), and running it.
#include <functional>
#include <optional>
#include <string>
#include <vector>
#include "varbo/registry.hpp"
#include "varbo/search_space.hpp"

namespace varbo {

struct TrialRecord;  // varbo/store.hpp

/// The validated top-level keys of a study file.
struct StudyConfig {
  ConfigNode source;
  ResolvedComponent task;
  ResolvedComponent algorithm;
  Index budget = 30;
  std::uint64_t seed = 1;
  int threads = 0;
  std::string output;
  std::optional<Vec> initial_point;  ///< user units
  double heartbeat_timeout = 60;     ///< a silent `varbo worker`'s pending trials are abandoned after it (0: never)
  bool retry_abandoned = false;      ///< re-queue an abandoned trial's θ as it is
  /// `varbo run` and `varbo worker` stop (exit 2, everything recorded) after this many failed trials in a row:
  /// an unplugged robot or a pressed E-stop must not burn the budget in a second (0: never stop).
  Index stop_after_failures = 10;
  /// `parameters:` (typed parameters, docs/search_space.md), validated; null when absent (the task's domain).
  SharedSpace parameters;
  /// `constraints:` as given (checked against the parameter names when the study is built); undefined if absent.
  ConfigNode constraints;
  YAML::Node resolved() const;       ///< every key with defaults, for config.resolved.yaml
};

/// The study's search space (docs/search_space.md), and `domain` (set from task.domain()) made its user box and
/// names: the declared `parameters:` given to the task (which must take them), or the task's own typed space, or —
/// with `constraints:` only — the task's box as real parameters; null for a plain box, which keeps every run
/// without these keys exactly as before. Throws ConfigError at the offending key, also when the algorithm or its
/// acquisition optimizer cannot handle the space (capability tags).
SharedSpace resolve_study_space(const StudyConfig& config, Task& task, Domain& domain);

/// Declared top-level keys (for validation and `varbo plugins --describe study`).
const std::vector<OptionSpec>& study_options();

/// Plugin paths named by the file's `plugin_path:` key (relative to the file), before validation.
std::vector<std::string> plugin_paths_of(const ConfigNode& root);

/// Validates `root` against the registry. Throws ConfigError with file:line:col on any problem.
StudyConfig parse_study(const ConfigNode& root, const Registry& registry);

struct RunOverrides {
  std::optional<int> threads;
  std::optional<std::uint64_t> seed;
  std::optional<std::string> output;
  std::optional<Index> budget;
  bool progress = true;  ///< one line per trial on stderr
  /// A study in a database: seconds to keep retrying (with backoff) a suggestion or a result whose connection was
  /// lost (a server restart, a network cut) before the run stops; 0 = stop at once (store_retry.hpp).
  double reconnect_seconds = 120;
  /// Study store of the run (default: <output>/study.db). An existing store is continued (its configuration
  /// must match); a new one is created.
  std::optional<std::string> store;
  /// Continue the run in `store` (or <output>/study.db) instead of starting afresh. Without it, a
  /// <output>/study.db holding trials is refused (InputError pointing at --resume and --overwrite).
  bool resume = false;
  /// Replace the study of <output>/study.db even if it holds trials.
  bool overwrite = false;
  /// For hosts that embed the runner (the Python module): polled like a stop signal, between trials and after a
  /// failed trial; a non-zero signal number stops the run as that signal would (Interrupted, trial abandoned).
  std::function<int()> stop_signal;
  /// Called with each trial once it is recorded; false ends the run after it (as a spent budget would). An
  /// exception propagates out of run_study with every recorded trial kept.
  std::function<bool(const TrialRecord&)> on_trial;
  /// How the host continues and replaces a run, for its messages ({} = the run folder): the CLI's by default; the
  /// Python module names minimize's arguments.
  std::string resume_hint = "`varbo run --resume {}`";
  std::string overwrite_hint = "pass --overwrite";
};

struct RunSummary {
  std::string output;
  Index evaluations = 0;
  Index failed = 0;
  std::optional<Vec> best_theta;        ///< user units, best observed cost
  double best_cost = 0;
  std::optional<Vec> recommended_theta; ///< user units, by the algorithm's recommendation rule
  std::string recommendation_rule;      ///< e.g. "lowest_mean_evaluated" (bo's `recommendation`), if known
  /// With typed parameters (`parameters:`): the two points as `name=value` (labels for categories), for report().
  std::string best_params, recommended_params;
  /// Where the optimum is known: noise-free cost of the recommended θ − f* (the regret of what a user
  /// deploys; needs Task::noiseless_cost).
  std::optional<double> regret_recommended;
  /// Where the optimum is known: lowest noise-free cost among evaluated θ − f* (an oracle figure: on a noisy
  /// task a user cannot know which evaluated θ that is).
  std::optional<double> regret_best_observed;
  double seconds = 0;
  std::string report() const;
};

/// Builds task and algorithm, runs the ask/evaluate/tell loop, and writes the run folder.
RunSummary run_study(const StudyConfig& study, const Registry& registry, const RunOverrides& overrides);

/// Loads plugins (default path + the file's plugin_path), validates and runs a study file.
RunSummary run_study_file(const std::string& config_file, const RunOverrides& overrides);

/// Continues an interrupted `varbo run`: `run_dir_or_store` is a run folder (holding study.db) or a study
/// file. The configuration comes from the store; trials already finished are replayed, not re-evaluated.
RunSummary resume_study(const std::string& run_dir_or_store, const RunOverrides& overrides);

}  // namespace varbo
