#include "dashboard_study.hpp"

#include <fmt/format.h>
#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "varbo/errors.hpp"
#include "varbo/host_task.hpp"
#include "varbo/log.hpp"
#include "varbo/math.hpp"
#include "varbo/state.hpp"
#include "varbo/numbers.hpp"

namespace fs = std::filesystem;

namespace varbo::cli {

namespace {

/// Studies varbo.minimize wrote name the task `python`, which only the Python module evaluates; its domain is
/// enough to show them (as `varbo status` does).
void read_only_components(Registry& registry) { add_host_python_task(registry); }

Study open_study(const std::string& address) {
  if (!is_database_url(address) && !fs::is_regular_file(address))
    throw InputError(fmt::format("{}: no such study (expected a study file, a run folder holding study.db, or a "
                                 "postgresql:// URL)",
                                 address));
  return Study::open(address, read_only_components);
}

}  // namespace

std::string dashboard_study_address(const std::string& arg) {
  if (!is_database_url(arg) && fs::is_directory(arg)) {
    const std::string db = (fs::path(arg) / "study.db").string();
    if (!fs::is_regular_file(db))
      throw InputError(fmt::format("{}: a folder without study.db (expected a run folder of `varbo run`, a study "
                                   "file or a postgresql:// URL)",
                                   arg));
    return db;
  }
  return arg;
}

DashboardStudy::DashboardStudy(const std::string& study, std::uint64_t seed)
    : address_(dashboard_study_address(study)),
      is_file_(!is_database_url(address_)),
      seed_(seed),
      study_(std::make_shared<Study>(open_study(address_))) {
  shown_ = study_->store().location();
  try {
    knows_optimum_ = study_->task().optimum().has_value();
  } catch (const std::exception&) {
    knows_optimum_ = false;  // a task only its host evaluates (minimize's python): no optimum known here
  }
  struct stat st {};
  if (is_file_ && ::stat(address_.c_str(), &st) == 0) {
    dev_ = static_cast<std::uint64_t>(st.st_dev);
    ino_ = static_cast<std::uint64_t>(st.st_ino);
  }
}

bool DashboardStudy::present() {
  if (!is_file_) return true;
  struct stat st {};
  if (::stat(address_.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return false;
  {
    std::lock_guard<std::mutex> lock(store_mutex_);
    if (static_cast<std::uint64_t>(st.st_dev) == dev_ && static_cast<std::uint64_t>(st.st_ino) == ino_) return true;
  }
  // Another file at the address (a study written in its place, a removed one restored): the open connection
  // still reads the old, unlinked file, and did so until a restart. Follow the address, as a new reader would.
  auto fresh = std::make_shared<Study>(open_study(address_));  // InputError (409) when it is not a study
  const auto model_lock = lock_model();
  std::lock_guard<std::mutex> lock(store_mutex_);
  study_ = std::move(fresh);
  dev_ = static_cast<std::uint64_t>(st.st_dev);
  ino_ = static_cast<std::uint64_t>(st.st_ino);
  regret_cache_.clear();
  model_.reset();
  ++generation_;
  log_info("dashboard: {} was replaced; opened it again", shown_);
  return true;
}

std::optional<std::string> DashboardStudy::summary_path() const {
  if (!is_file_) return std::nullopt;
  return (fs::path(address_).parent_path() / "summary.json").string();
}

std::vector<TrialRecord> DashboardStudy::trials() const {
  std::lock_guard<std::mutex> lock(store_mutex_);
  return study_->trials();
}

std::vector<StoredSnapshot> DashboardStudy::snapshots() const {
  std::lock_guard<std::mutex> lock(store_mutex_);
  return study_->model_snapshots();
}

std::size_t DashboardStudy::workers() const {
  std::lock_guard<std::mutex> lock(store_mutex_);
  // Live ones only, as `varbo status` counts them: running, not known gone, heard from within the study's
  // heartbeat_timeout (60 s where it is 0). Every worker ever seen was counted ("workers: 4" with none running;
  // red team, session 46).
  const double now = unix_time();
  const double window = study_->config().heartbeat_timeout > 0 ? study_->config().heartbeat_timeout : 60.0;
  std::size_t live = 0;
  for (const WorkerRecord& w : study_->store().workers())
    live += w.state == "running" && now - w.heartbeat_at < window && !worker_process_gone(w.id);
  return live;
}

std::optional<double> DashboardStudy::regret_recommended(std::int64_t row) const {
  std::lock_guard<std::mutex> lock(store_mutex_);
  if (auto it = regret_cache_.find(row); it != regret_cache_.end()) return it->second;
  std::optional<double> v;
  if (auto text = study_->meta(fmt::format("regret_recommended/{}", row))) v = strtod_c(text->c_str(), nullptr);
  if (v) regret_cache_[row] = v;  // a row without a value yet may get one once `varbo run` writes it
  return v;
}

RunFolder DashboardStudy::run_view(const std::vector<TrialRecord>& trials,
                                   const std::vector<StoredSnapshot>& snapshots) const {
  const std::shared_ptr<const Study> study = this->study();
  RunFolder run;
  run.folder = is_file_ ? address_ : shown_;
  run.study = study->config();
  run.domain = study->domain();
  run.space = study->space();
  run.names = run.domain.names;
  const Index d = run.domain.box.dim();
  for (Index i = static_cast<Index>(run.names.size()); i < d; ++i) run.names.push_back(fmt::format("x{}", i + 1));
  run.initial_point = run.study.initial_point;
  // trials.csv holds the finished trials in finish order; the model learns from the complete ones.
  std::vector<const TrialRecord*> finished;
  for (const auto& t : trials)
    if (t.finished()) finished.push_back(&t);
  std::sort(finished.begin(), finished.end(),
            [](const TrialRecord* a, const TrialRecord* b) { return a->finish_seq < b->finish_seq; });
  run.trials = static_cast<Index>(finished.size());
  for (const auto* t : finished)
    for (const auto& [name, v] : t->components)
      if (std::find(run.components.begin(), run.components.end(), name) == run.components.end())
        run.components.push_back(name);
  std::vector<const TrialRecord*> ok;
  for (const auto* t : finished)
    if (t->state == TrialState::Complete && t->theta.allFinite() && std::isfinite(t->cost)) ok.push_back(t);
  const Index n = static_cast<Index>(ok.size());
  run.theta.resize(n, d);
  run.cost.resize(n);
  run.component_values = Mat::Constant(n, static_cast<Index>(run.components.size()), std::nan(""));
  run.data = Dataset::empty(run.space ? run.space->encoded_dim() : d);
  for (Index i = 0; i < n; ++i) {
    const TrialRecord& t = *ok[static_cast<std::size_t>(i)];
    run.theta.row(i) = t.theta.transpose();
    run.cost[i] = t.cost;
    run.phases.push_back(t.phase);
    for (const auto& [name, v] : t.components)
      run.component_values(i, std::find(run.components.begin(), run.components.end(), name) - run.components.begin()) = v;
    // The same mapping as load_run_folder: θ in user units back into the unit cube.
    run.data.add(unit_point(run, t.theta), t.cost);
  }
  // Failed trials, as load_run_folder reads them (ok = 0 in trials.csv): the κ selection keeps away from them.
  std::vector<Vec> failed;
  for (const auto* t : finished)
    if (t->state == TrialState::Failed && t->theta.size() == d && t->theta.allFinite())
      failed.push_back(unit_point(run, t->theta));
  run.failed.resize(static_cast<Index>(failed.size()), run.data.dim());
  for (std::size_t i = 0; i < failed.size(); ++i) run.failed.row(static_cast<Index>(i)) = failed[i].transpose();
  for (const auto& s : snapshots) run.fits.push_back(s.snapshot.hyperparameters);
  return run;
}

std::shared_ptr<const DashboardModel> DashboardStudy::model() {
  const auto all = trials();
  const auto complete = static_cast<std::int64_t>(
      std::count_if(all.begin(), all.end(), [](const TrialRecord& t) { return t.state == TrialState::Complete; }));
  // Failed trials count too: the selections keep away from them (it served the model of before 3 new failures,
  // choosing a θ right beside two of them; red team, session 27).
  const auto failed = static_cast<std::int64_t>(
      std::count_if(all.begin(), all.end(), [](const TrialRecord& t) { return t.state == TrialState::Failed; }));
  if (model_ && model_->complete == complete && model_->failed == failed) return model_;
  if (complete < 2)
    throw InputError(fmt::format("{}: {} complete trial(s); a model needs at least 2", shown_, complete));
  auto m = std::make_shared<DashboardModel>();
  m->run = run_view(all, snapshots());
  m->complete = complete;
  m->failed = failed;
  m->seed = seed_;
  const std::shared_ptr<const Study> study = this->study();  // kept alive while the fit uses its registry
  const Registry& registry = study->registry();
  const auto start = std::chrono::steady_clock::now();
  // Between full fits the last fit's model is conditioned on the new trials, as bo does between its full fits
  // (a full fit when the data grew by a quarter): the page asks for the model whenever a trial completes, and a
  // full fit per trial kept the server fitting back to back (9.6 s each at N = 500; red team, session 25).
  bool conditioned = false;
  if (model_ && complete < model_->full_fit_complete + std::max<std::int64_t>(1, model_->full_fit_complete / 4)) {
    if (const ComponentState* before = state_of(model_->fitted.model.get())) {
      try {
        FittedRunModel f;
        f.spec = model_->fitted.spec;
        f.model = make_run_surrogate(m->run, f.spec, registry, seed_, false);
        if (ComponentState* now = state_of(f.model.get())) {
          now->restore_state(before->save_state());
          f.report = f.model->condition(m->run.data);
          if (f.report.ok && f.model->ready()) {
            m->fitted = std::move(f);
            m->full_fit_complete = model_->full_fit_complete;
            conditioned = true;
          }
        }
      } catch (const std::exception& e) {
        log_debug("dashboard: conditioning the last fit failed ({}); fitting afresh", e.what());
      }
    }
  }
  if (!conditioned) {
    m->fitted = fit_selection_model(m->run, registry, selection_surrogate(m->run, registry, "", shown_), seed_, true);
    m->full_fit_complete = complete;
  }
  m->fit_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  m->optimizer = make_selection_optimizer(m->run, registry, kSelectOptimizer, "optimizer", seed_);
  m->recommended = select_among(*m->fitted.model, m->run.domain, {0.0}, m->run.data.X, m->run.space).at(0);
  log_info("dashboard: {} {} on {} complete trials in {:.3f} s", conditioned ? "conditioned the last fit of" : "fitted",
           m->fitted.spec.info->full_name(), complete, m->fit_seconds);
  model_ = std::move(m);
  return model_;
}

}  // namespace varbo::cli
