#pragma once
// Writes a run folder incrementally: every row is flushed when it happens, summary.json is replaced
// atomically, so an interrupted run loses nothing already recorded.
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "varbo/algorithm.hpp"
#include "varbo/store.hpp"
#include "varbo/study.hpp"
#include "varbo/task.hpp"

namespace varbo {

/// A line of trials.csv: the stored trial (the one representation from ask to row) and what the run adds.
struct TrialRow {
  Index index = 0;     ///< position in finish order
  TrialRecord trial;   ///< as stored: phase, θ, state, cost, components, error, timings
  bool ok() const { return trial.state == TrialState::Complete; }
  /// Where the optimum is known: after this trial, the noise-free cost of the best observed θ − f*, and of
  /// the θ the algorithm recommends − f* (NaN when the task cannot evaluate it without noise).
  double regret_best_observed = std::numeric_limits<double>::quiet_NaN();
  double regret_recommended = std::numeric_limits<double>::quiet_NaN();
};

class RunWriter {
 public:
  /// `plugin_paths`: the third-party plugins the study loaded (absolute), written into config.resolved.yaml as
  /// `plugin_path:` relative to the run folder, so the file re-runs and the offline commands find them.
  RunWriter(const std::string& folder, const StudyConfig& study, const Domain& domain,
            std::vector<std::string> component_names, bool with_regret = false, SharedSpace space = nullptr,
            const std::vector<std::string>& plugin_paths = {});
  ~RunWriter();
  RunWriter(const RunWriter&) = delete;
  RunWriter& operator=(const RunWriter&) = delete;
  /// trials.csv and model.yaml are written aside (.tmp) until this call renames them into place: a resumed run
  /// rewrites every earlier row first, and a reader saw the files empty or half-written meanwhile.
  void publish();
  void trial(const TrialRow& row);
  void model(const ModelSnapshot& snapshot);
  void summary(const RunSummary& summary, const Domain& domain, const std::optional<Optimum>& optimum);
  const std::string& folder() const { return folder_; }
  /// The run folder's files that are not up to date because writing them failed (trials.csv, summary.json): said
  /// again at the end of the run, where a warning at trial 3 of an overnight run scrolled away (red team, session
  /// 46: a folder made read-only mid-run left summary.json at 3 evaluations, exit 0).
  std::vector<std::string> stale_files() const;
  /// The study the run folder belongs to, written into summary.json as "study" (an absolute path, or the URL with
  /// its password hidden): a later run of another study refuses to overwrite the folder (study_run.cpp).
  void set_study(std::string study) { study_ = std::move(study); }

 private:
  /// Where `name` is written before it is renamed into place: per process, so that one left by another user's
  /// killed run cannot block this one (a fixed trials.csv.tmp of theirs made "trials.csv: cannot write"; red team,
  /// session 29).
  std::string aside(const std::string& name) const;
  void remove_stale_asides() const;
  std::string description_;  ///< the configuration's `description`, repeated in summary.json
  std::string folder_;
  std::vector<std::string> components_;
  std::ofstream trials_, model_;
  bool published_ = false;
  bool warned_extra_ = false;
  std::vector<std::string> warned_missing_;  ///< declared components said once each to be missing from a success
  bool trials_warned_ = false;   // trials.csv could not be written (said once)
  bool summary_warned_ = false;  // summary.json could not be written (said once)
  bool summary_stale_ = false;   // the last summary.json could not be written
  bool with_regret_ = false;  ///< trials.csv carries regret_best_observed and regret_recommended
  SharedSpace space_;         ///< typed parameters: θ written as labels and integers
  std::string study_;
};

}  // namespace varbo
