#pragma once
// What `varbo dashboard` reads: one study (a study file, a run folder's study.db or a PostgreSQL URL) opened
// read-only through varbo::Study, and the fitted surrogate of its complete trials, cached until a new trial
// completes (a κ-slider move then costs a search, never a refit).
#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "../run_selection.hpp"
#include "varbo/run_folder.hpp"
#include "varbo/study_api.hpp"

namespace varbo::cli {

/// The study seen as the run folder `varbo select` would read (successful trials in finish order, the
/// hyperparameters of each stored model snapshot), with the model fitted on it.
struct DashboardModel {
  RunFolder run;
  FittedRunModel fitted;
  std::unique_ptr<Optimizer> optimizer;
  std::int64_t complete = 0;  ///< complete trials the model was fitted on (the cache key, with `failed`)
  std::int64_t failed = 0;    ///< failed trials when it was made (the selections keep away from them)
  std::int64_t full_fit_complete = 0;  ///< complete trials at the last full fit (conditioned since, up to +25 %)
  std::uint64_t seed = 1;
  double fit_seconds = 0;
  /// The point the views cut through: among the evaluated θ, argmin of the posterior mean (κ = 0).
  RiskSelection recommended;
};

class DashboardStudy {
 public:
  /// `study`: a file, a run folder (its study.db) or a postgresql:// URL. InputError when there is no study.
  /// `seed`: of the fit and the selection search (`varbo select --seed`).
  DashboardStudy(const std::string& study, std::uint64_t seed);

  const std::string& address() const { return address_; }
  /// The address for people to read: a PostgreSQL URL's password hidden (the page, /api/summary and the log
  /// showed it to whoever could reach the dashboard; red team, session 30).
  const std::string& shown() const { return shown_; }
  /// Whether the study's task knows its optimum (then `varbo run` records per-row regrets).
  bool knows_optimum() const { return knows_optimum_; }
  /// False when the study file has gone since the server started (a request then answers 404). A file replaced
  /// since it was opened (another study written in its place, a deleted one restored) is opened again, and the
  /// model cache dropped; InputError when the new file is not a study.
  bool present();
  std::shared_ptr<const Study> study() const {
    std::lock_guard<std::mutex> lock(store_mutex_);
    return study_;
  }
  /// Bumped whenever the study file is opened again (a cache key of answers computed from it).
  std::uint64_t generation() const { return generation_.load(); }

  /// Short reads of the store, one at a time (the store object is not shared between threads).
  std::vector<TrialRecord> trials() const;
  std::vector<StoredSnapshot> snapshots() const;
  std::size_t workers() const;
  /// `varbo run`'s regret of the recommended θ after finished trial `row` (0-based), where the task knows its
  /// optimum; cached, as a row's value never changes.
  std::optional<double> regret_recommended(std::int64_t row) const;

  /// The model on the complete trials now in the store, refitted only when that number changed. InputError when
  /// no model can be had (fewer than 2 complete trials; an algorithm without a surrogate gets the default gp). The caller must hold
  /// the lock returned by lock_model() while it uses the model (surrogates are not made for concurrent use).
  std::shared_ptr<const DashboardModel> model();
  std::unique_lock<std::mutex> lock_model() const { return std::unique_lock<std::mutex>(model_mutex_); }

  /// summary.json beside a study file (a `varbo run` folder): the learned policy `varbo rescore` starts from.
  std::optional<std::string> summary_path() const;

  /// The run folder `varbo select` would read for these trials and model snapshots.
  RunFolder run_view(const std::vector<TrialRecord>& trials, const std::vector<StoredSnapshot>& snapshots) const;

 private:
  std::string address_;
  std::string shown_;
  bool knows_optimum_ = false;
  bool is_file_ = false;
  std::uint64_t seed_;
  std::shared_ptr<Study> study_;  ///< guarded by store_mutex_ (swapped when the file is replaced)
  std::uint64_t dev_ = 0, ino_ = 0;  ///< the identity of the file study_ has open
  std::atomic<std::uint64_t> generation_{0};
  mutable std::mutex store_mutex_;
  mutable std::mutex model_mutex_;
  mutable std::map<std::int64_t, std::optional<double>> regret_cache_;
  std::shared_ptr<const DashboardModel> model_;
};

/// The study address of a `varbo dashboard` argument: a run folder's study.db, else the argument itself.
std::string dashboard_study_address(const std::string& arg);

}  // namespace varbo::cli
