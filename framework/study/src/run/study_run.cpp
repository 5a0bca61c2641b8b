// The ask / evaluate / tell loop of `varbo run`.
#include <cxxabi.h>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <yaml-cpp/yaml.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <unordered_map>
#include <vector>
#include <optional>
#include <set>
#include <filesystem>
#include <cmath>
#include <cstdio>
#include <limits>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "owner_identity.hpp"
#include "run_writer.hpp"
#include "store_guard.hpp"
#include "varbo/run_liveness.hpp"
#include "../store/store_url.hpp"
#include "../study/stored_plugin_paths.hpp"
#include "../study/plugin_code.hpp"
#include "../study/study_impl.hpp"
#include "varbo/csv.hpp"
#include "varbo/errors.hpp"
#include "varbo/regular_file.hpp"
#include "varbo/interrupt.hpp"
#include "varbo/loader.hpp"
#include "varbo/log.hpp"
#include "varbo/math.hpp"
#include "varbo/parallel.hpp"
#include "varbo/run_lock.hpp"
#include "varbo/store.hpp"
#include "varbo/store_retry.hpp"
#include "varbo/study.hpp"
#include "varbo/study_api.hpp"
#include "varbo/text.hpp"
#include "varbo/numbers.hpp"

namespace varbo {

namespace {
double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
/// The summary's θ has at most this many components written out; past it the first and last few (a run of 3668
/// parameters printed 70 KB per line; audit, session 45): the whole θ is in summary.json and trials.csv.
constexpr Index kShownComponents = 24;
/// Whether component i of n is written out, and whether the elision goes before it.
bool shown(Index i, Index n) { return n <= kShownComponents || i < kShownComponents - 4 || i >= n - 4; }
std::string elided(Index n) {
  return fmt::format(", … {} more (summary.json, trials.csv) …", n - kShownComponents);
}
std::string fmt_vec(const Vec& v) {
  std::string s = "[";
  // Every digit: the θ printed is the one a user deploys or copies (at 6 digits, all of [1e6, 1e6 + 1] was 1e+06).
  for (Index i = 0; i < v.size(); ++i) {
    if (!shown(i, v.size())) continue;
    if (i == v.size() - 4 && v.size() > kShownComponents) s += elided(v.size());
    s += fmt::format("{}{}", i ? ", " : "", exact(v[i]));
  }
  return s + "]";
}
/// "5", or "5 (study id 6)" once the two numberings differ (after an abandoned trial): the log speaks of the row
/// of trials.csv, `varbo status` and `export` of the study's id.
std::string trial_label(Index index, std::int64_t id) {
  return index == id ? std::to_string(index) : fmt::format("{} (study id {})", index, id);
}
/// `lr=0.001, solver=lqr`: what a user of typed parameters reads (θ holds a category's index, not its label).
std::string params_text(const SearchSpace& space, const Vec& theta) {
  std::string s;
  const auto n = static_cast<Index>(space.parameters().size());
  for (std::size_t i = 0; i < space.parameters().size(); ++i) {
    const auto at = static_cast<Index>(i);
    if (!shown(at, n)) continue;
    if (at == n - 4 && n > kShownComponents) s += elided(n);
    s += fmt::format("{}{}={}", i ? ", " : "", space.parameters()[i].name,
                     safe_text(space.format_value(i, theta[static_cast<Index>(i)]), 40));
  }
  return s;
}
}  // namespace

std::string RunSummary::report() const {
  std::string s = fmt::format("varbo run summary\n  output          {}\n  evaluations     {} ({} failed)\n", output,
                              evaluations, failed);
  if (best_theta)
    s += fmt::format("  best cost       {:.8g} at {}\n", best_cost, best_params.empty() ? fmt_vec(*best_theta) : best_params);
  else if (evaluations > 0)
    s += "  best cost       none: every trial failed (their reasons are in trials.csv and log.txt)\n";
  if (recommended_theta)
    s += fmt::format("  recommended     {}{}\n", recommended_params.empty() ? fmt_vec(*recommended_theta) : recommended_params,
                     recommendation_rule.empty() ? std::string() : " (" + recommendation_rule + ")");
  if (regret_recommended) s += fmt::format("  regret of the recommended θ     {:.3e}\n", *regret_recommended);
  // The oracle figure (summary.json's regret_best_observed): the lowest noise-free regret among the evaluated θ,
  // which under noise need not be the θ of the best observed cost printed above.
  if (regret_best_observed) s += fmt::format("  lowest regret of an evaluated θ {:.3e}  (oracle: noise-free)\n", *regret_best_observed);
  s += fmt::format("  wall time       {:.2f} s\n", seconds);
  return s;
}

namespace {

/// The run folder and those above it that this command makes, removed again (empty ones only, innermost first)
/// when the command is rejected before its study exists: a `-o` path whose study SQLite refused as too long left
/// its whole empty folder tree behind (red team, session 37).
class MadeFolders {
 public:
  explicit MadeFolders(const std::string& folder) {
    namespace fs = std::filesystem;
    std::error_code ec;
    fs::path prefix;
    for (const fs::path& part : fs::absolute(folder, ec)) {
      prefix /= part;
      if (!fs::exists(fs::symlink_status(prefix, ec))) made_.push_back(prefix);
    }
  }
  MadeFolders(const MadeFolders&) = delete;
  MadeFolders& operator=(const MadeFolders&) = delete;
  ~MadeFolders() {
    if (kept_) return;
    std::error_code ec;
    for (auto it = made_.rbegin(); it != made_.rend(); ++it) std::filesystem::remove(*it, ec);  // not if not empty
  }
  /// The study is in place: the folders are the run's.
  void keep() { kept_ = true; }

 private:
  std::vector<std::filesystem::path> made_;
  bool kept_ = false;
};

void remove_store_files(const std::string& path) {
  std::error_code ec;
  for (const char* suffix : {"", "-wal", "-shm", "-journal"}) std::filesystem::remove(path + suffix, ec);
}

bool same_file(const std::string& a, const std::string& b) {
  std::error_code ec;
  if (std::filesystem::exists(a, ec) && std::filesystem::exists(b, ec)) return std::filesystem::equivalent(a, b, ec);
  return std::filesystem::weakly_canonical(a, ec) == std::filesystem::weakly_canonical(b, ec);
}

/// How summary.json names the study: an absolute path, or a database URL with its password hidden.
std::string study_tag(const std::string& store_path) {
  if (is_database_url(store_path)) return parse_postgres_address(store_path).display;
  return std::filesystem::absolute(store_path).lexically_normal().string();
}

/// A run folder holds one study's files (trials.csv, summary.json, config.resolved.yaml, model.yaml): a run of
/// another study there replaced them silently — two study files in one folder, each `--resume`d, took turns
/// overwriting it (red team, session 23). The folder's summary.json names its study ("study"); folders written
/// before that say nothing and are not checked.
std::optional<std::string> other_studys_folder(const std::string& folder, const std::string& store_path) {
  // The folder's own study.db is its study, whatever summary.json says: a copied or moved run folder names the
  // original's path there until it is resumed.
  if (same_file((std::filesystem::path(folder) / "study.db").string(), store_path)) return std::nullopt;
  const std::string summary = (std::filesystem::path(folder) / "summary.json").string();
  if (!absent_or_regular_file(summary)) return std::nullopt;  // a FIFO would block
  std::ifstream in(summary);
  if (!in) return std::nullopt;
  nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  if (j.is_discarded() || !j.is_object() || !j.contains("study") || !j["study"].is_string()) return std::nullopt;
  const std::string other = j["study"].get<std::string>();
  const bool same = is_database_url(store_path) ? other == study_tag(store_path)
                                                : !is_database_url(other) && same_file(other, store_path);
  return same ? std::nullopt : std::optional<std::string>(other);
}

/// True when `folder` is `store_path`'s own run folder: the study file inside it, its summary.json naming the
/// study, or the folder the study recorded as its run folder.
bool this_studys_folder(const std::string& folder, const std::string& store_path, const StudyStore& store) {
  namespace fs = std::filesystem;
  if (same_file((fs::path(folder) / "study.db").string(), store_path)) return true;
  if (const auto out = store.meta(store_key::kOutput); out && same_file(*out, folder)) return true;
  const std::string summary = (fs::path(folder) / "summary.json").string();
  if (!absent_or_regular_file(summary)) return false;  // a FIFO would block
  std::ifstream in(summary);
  if (!in) return false;
  nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  return !j.is_discarded() && j.is_object() && j.contains("study") && j["study"].is_string() &&
         !other_studys_folder(folder, store_path);
}

void refuse_other_studys_folder(const std::string& folder, const std::string& store_path, const RunOverrides& ov) {
  const auto other = other_studys_folder(folder, store_path);
  if (!other) return;
  throw InputError(fmt::format("{}: this folder holds the run files (trials.csv, summary.json) of another study, {}; "
                               "a run of {} would replace them. Give it a run folder of its own with -o DIR{}",
                               folder, *other, store_path,
                               ov.resume ? std::string() : ", or " + ov.overwrite_hint + " to replace them"));
}

/// `--overwrite` of a study that live workers are working on: the result of each trial in flight, measured on the
/// robot, would land nowhere and the workers stop (red team, session 46: exit 0, the worker's cost 2.33 lost). A
/// worker is live while its process is not known gone and its heartbeat is within the stored heartbeat_timeout.
void refuse_to_overwrite_live_workers(const std::string& store_path) {
  std::unique_ptr<StudyStore> store;
  try {
    store = open_sqlite_store(store_path);
  } catch (const std::exception&) {
    return;  // not a readable study: refuse_to_overwrite_foreign has judged the file
  }
  double timeout = 60;
  if (const auto text = store->meta(store_key::kConfig)) {
    try {
      const YAML::Node t = YAML::Load(*text)["heartbeat_timeout"];
      if (t && t.IsScalar()) timeout = t.as<double>();
    } catch (const std::exception&) {
    }
  }
  const std::vector<TrialRecord> pending = store->pending_trials();
  const double now = unix_time();
  std::vector<std::string> live;
  Index trials = 0;
  for (const WorkerRecord& w : store->workers()) {
    if (w.state != "running" || worker_process_gone(w.id)) continue;
    if (timeout > 0 && now - w.heartbeat_at > timeout) continue;
    const auto held = std::count_if(pending.begin(), pending.end(), [&](const TrialRecord& t) { return t.worker == w.id; });
    if (held == 0) continue;
    trials += static_cast<Index>(held);
    live.push_back(fmt::format("{} (heartbeat {:.0f} s ago)", w.id, std::max(0.0, now - w.heartbeat_at)));
  }
  if (!live.empty())
    throw InputError(fmt::format(
        "{}: --overwrite would erase a study that live workers are working on: {} trial(s) in flight by {}; their "
        "results would be lost. Stop the workers first (Ctrl-C, or SIGTERM), or run into another folder",
        store_path, trials, fmt::join(live, ", ")));
}

/// `--overwrite` replaces a study file: not a file that is no study at all, and not the study of another run folder
/// (`run CFG -o B --study A/study.db --overwrite` erased run A's trials, and `--study cfg.yaml --overwrite` turned
/// the configuration into a database, both with exit 0; audit, session 44).
void refuse_to_overwrite_foreign(const std::string& folder, const std::string& store_path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::exists(fs::symlink_status(store_path, ec))) return;
  if (!fs::is_regular_file(store_path, ec))
    throw InputError(fmt::format("{}: --overwrite replaces a study file, and this is not a plain file; give --study a "
                                 "study's file or a new path", store_path));
  const auto size = fs::file_size(store_path, ec);
  if (!ec && size > 0) {
    char head[16] = {};
    std::ifstream in(store_path, std::ios::binary);
    in.read(head, sizeof head);
    if (in.gcount() != static_cast<std::streamsize>(sizeof head) ||
        std::string(head, sizeof head) != std::string("SQLite format 3\0", 16))
      throw InputError(fmt::format("{}: --overwrite replaces a study file, and this is not one (not an SQLite "
                                   "database); give --study a study's file or a new path", store_path));
  }
  // The study of another run folder: its own study.db, in a folder with run files.
  const fs::path parent = fs::path(store_path).parent_path().empty() ? fs::path(".") : fs::path(store_path).parent_path();
  if (fs::path(store_path).filename() != "study.db" || same_file(parent.string(), folder)) return;
  for (const char* name : {"trials.csv", "summary.json", "config.resolved.yaml"})
    if (fs::exists(parent / name, ec))
      throw InputError(fmt::format("{}: this is the study of the run folder {}; --overwrite here would erase that "
                                   "run's trials. Give this run a study file of its own (--study NEW.db), or replace "
                                   "that run in its own folder (varbo run CONFIG -o {} --overwrite)",
                                   store_path, parent.string(), shell_word(parent.string())));
}

/// A plain `varbo run` on a folder whose study holds trials would silently discard them: refuse.
void refuse_to_replace(const std::string& folder, const std::string& store_path, const RunOverrides& ov,
                       const std::string& identity_now, Index budget_now) {
  std::size_t n = 0;
  std::string differs;
  try {
    const auto store = open_sqlite_store(store_path);
    n = store->trials().size();
    // A raised budget is no new study: the advice to resume dropped it in silence (audit, session 48: the study
    // "extended overnight" had finished at once). Named, with the option that carries it.
    if (const auto text = store->meta(store_key::kConfig)) {
      const YAML::Node stored = YAML::Load(*text);
      if (stored.IsMap() && stored["budget"] && stored["budget"].IsScalar() &&
          stored["budget"].Scalar() != std::to_string(budget_now))
        differs = fmt::format(". The configuration given has budget {} (the study's is {}): resuming keeps the "
                              "study's unless given anew, {}",
                              budget_now, stored["budget"].Scalar(),
                              ov.resume_hint.find("varbo run --resume") != std::string::npos
                                  ? fmt::format("`varbo run --resume {} --budget {}`", shell_word(folder), budget_now)
                                  : std::string("with the budget given again"));
    }
    // An edited configuration re-run on its folder: the advice to resume was followed and the edits (bounds, a
    // budget) were dropped in silence (red team, session 28). Said, with where it differs.
    if (const auto stored = store->meta(store_key::kIdentity);
        stored && !study_detail::same_identity(*stored, identity_now))
      differs += fmt::format(". The configuration given differs from the study's ({}): a resumed run continues the "
                            "study as it was created (a budget is raised with --budget); a changed configuration "
                            "is a new study, in another folder (-o)",
                            study_detail::first_difference(*stored, identity_now));
  } catch (const Error& e) {
    throw InputError(fmt::format("{}: the run folder holds a study file that cannot be read ({}); move it away, or "
                                 "{} to replace it",
                                 folder, e.what(), ov.overwrite_hint));
  }
  if (n == 0) return;
  throw InputError(fmt::format("{}: this run folder holds a study with {} trial(s) ({}); continue it with {}, or "
                               "{} to replace it (its trials are lost){}",
                               folder, n, store_path, fmt::format(fmt::runtime(ov.resume_hint), folder),
                               ov.overwrite_hint, differs));
}

}  // namespace

namespace {
RunSummary run_study_logged(const StudyConfig& study_in, const Registry& registry, const RunOverrides& ov);
}

RunSummary run_study(const StudyConfig& study_in, const Registry& registry, const RunOverrides& ov) {
  try {
    return run_study_logged(study_in, registry, ov);
  } catch (const Interrupted&) {
    throw;  // said in the log already, with the command that continues the run
  } catch (const std::exception& e) {
    // The caller prints it; log.txt must hold it too (a run's log ended without the reason it stopped).
    log_file_message(LogLevel::Error, e.what());
    set_log_file("");
    throw;
  }
}

namespace {
/// The task's known optimum, when it can be reached in the study's search space. `task: branin` with
/// `constraints: ["x1 + x2 <= 4"]` cuts off all three minimizers, and the regret figures against Branin's 0.398
/// could never reach 0 (2.0 where the constrained optimum was reached; red team, session 24). Left out then, said
/// once; likewise when typed parameters or constraints restrict a task whose minimizers are not given.
std::optional<Optimum> admissible_optimum(Task& task, const SharedSpace& space, const std::string& task_name) {
  // A third-party task's optimum() throwing ended the run as an "internal error" (red team, session 28).
  std::optional<Optimum> optimum;
  if (const std::string why = detail::what_it_threw<Error>([&] { optimum = task.optimum(); }); !why.empty())
    log_warn("task '{}': its known optimum could not be read ({}); no regret figures", task_name, why);
  // A non-finite optimum cost printed "regret … nan" without a word, and a θ of another dimension was taken in
  // silence (a third-party task; audit, session 48).
  if (optimum && !std::isfinite(optimum->cost)) {
    log_warn("task '{}': its known optimum cost is {}; no regret figures (optimum() should give a finite cost, or "
             "nothing when the optimum is unknown)",
             task_name, optimum->cost);
    return std::nullopt;
  }
  if (optimum && !space) {  // a typed space checks its own (below)
    const Index dim = task.domain().box.dim();
    for (const Vec& theta : optimum->thetas)
      if (theta.size() != dim || !theta.allFinite()) {
        log_warn("task '{}': a minimizer of its known optimum has {}; no regret figures (expected {} finite "
                 "coordinates)",
                 task_name, theta.size() != dim ? fmt::format("{} coordinates", theta.size()) : "a non-finite coordinate",
                 dim);
        return std::nullopt;
      }
  }
  if (!optimum || !space) return optimum;
  std::string why;
  for (const Vec& theta : optimum->thetas)
    if (theta.size() == static_cast<Index>(space->parameters().size()) && space->contains(theta, &why)) return optimum;
  log_warn("task '{}': its known optimum ({:g}) {} the search space (parameters:/constraints:){}; the regret figures "
           "are left out (a task with the constraints built in, e.g. branin_constrained, has its own)",
           task_name, optimum->cost, optimum->thetas.empty() ? "may lie outside" : "lies outside",
           why.empty() ? "" : fmt::format(" ({})", why));
  return std::nullopt;
}

RunSummary run_study_logged(const StudyConfig& study_in, const Registry& registry, const RunOverrides& ov) {
  StudyConfig study = study_in;
  if (ov.threads) study.threads = *ov.threads;
  if (ov.seed) {
    // The study stores its seed as a setting (an int64): a larger one ran every trial and then left a study that
    // neither `status` nor a resume could read (minimize(seed=2**63) in Python; red team, session 46).
    if (*ov.seed > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max()))
      throw InputError(fmt::format("seed {} is beyond the largest seed a study stores ({})", *ov.seed,
                                   std::numeric_limits<std::int64_t>::max()));
    study.seed = *ov.seed;
  }
  if (ov.output) study.output = *ov.output;
  if (ov.budget) study.budget = *ov.budget;
  ThreadLimit limit(study.threads);
  const auto t_start = std::chrono::steady_clock::now();

  // Every configuration error surfaces before anything is created (no empty run folder left behind).
  Study::validate(study, registry);
  if (is_database_url(study.output))
    // It made a folder tree named after the URL ("postgresql:/varbo@/db?host=…&study=gait/") and then refused the
    // "study name 'gait/study.db'".
    throw InputError(fmt::format("output '{}' is a study address, not a run folder: the run folder holds trials.csv, "
                                 "summary.json and the plots; a study in a database is given with `--study URL` "
                                 "(Python: varbo.Study with a URL)",
                                 study.output));

  // The run folder's path is kept in the study's YAML configuration and in summary.json, which are UTF-8: a
  // Latin-1 'é' in it ended the run with exit 3 at the summary and made the study unreadable (red team, session 28).
  {
    std::error_code ec;
    const std::string where = std::filesystem::absolute(study.output, ec).string();
    if (const std::size_t at = invalid_utf8_at(where); at != std::string::npos)
      throw InputError(fmt::format("{}: the run folder's path is not UTF-8 text (byte 0x{:02X} at offset {}); the "
                                   "study records it in its configuration, which is UTF-8: use a folder whose path "
                                   "is UTF-8 (e.g. convmv, or another -o)",
                                   printable(where), static_cast<unsigned char>(where[at]), at));
  }
  // The study store: every trial is committed there before it appears in trials.csv, so a killed run can be
  // continued with --resume (docs/studies.md).
  const bool own_store = !ov.store;  // <output>/study.db, not a study file given with --study
  const std::string store_path = ov.store ? *ov.store : study.output + "/study.db";
  // What `varbo run --resume` takes to continue this run: the folder when it holds the study, else the study
  // itself (`--study elsewhere.db` or a PostgreSQL URL: "--resume FOLDER" found no study.db there).
  const std::string resume_target = shell_word(ov.store ? *ov.store : study.output);
  if (ov.resume && !store_exists(store_path))
    throw InputError(fmt::format("{}: no study store to resume", store_path));
  if (ov.overwrite && !ov.resume && !is_database_url(store_path)) refuse_to_overwrite_foreign(study.output, store_path);
  if (own_store && !ov.resume && !ov.overwrite && !std::filesystem::exists(store_path)) {
    // Files a run writes, in a folder without its study: someone's own files (a project folder given as the run
    // folder: its model.yaml and summary.json were replaced in silence; red team, session 30), or a run whose
    // study.db is gone. Writing the run here replaced them (session 20: trials.csv).
    std::vector<std::string> found;
    // log.txt too: a run writes it from its first line (replaced in silence; audit, session 44).
    for (const char* name : {"trials.csv", "model.yaml", "summary.json", "config.resolved.yaml", "log.txt"})
      if (std::filesystem::exists(study.output + "/" + name)) found.push_back(name);
    if (!found.empty())
      throw InputError(fmt::format("{}: the folder holds {} but no study.db; a run here would replace {}. Choose "
                                   "another folder, or {} to replace {}",
                                   study.output, join(found, ", "), found.size() > 1 ? "them" : "it",
                                   ov.overwrite_hint, found.size() > 1 ? "them" : "it"));
  }
  if (!ov.overwrite && !same_file(study.output + "/study.db", store_path))
    refuse_other_studys_folder(study.output, store_path, ov);
  MadeFolders made_folders(study.output);  // before the locks: their files go first when it is rejected
  {
    std::error_code ec;
    std::filesystem::create_directories(study.output, ec);
    if (ec) throw InputError(fmt::format("{}: cannot create the run folder: {}", study.output, ec.message()));
  }
  // One driver per study and per run folder (docs/studies.md, "One writer"): held until this function returns,
  // after the store is closed (declared before it).
  std::vector<RunLock> locks;
  // A database study has no lock file (no shared folder to hold it): an advisory lock on the server instead.
  std::optional<DatabaseRunLock> database_lock;
  if (is_database_url(store_path))
    database_lock.emplace(DatabaseRunLock::acquire(store_path));
  else
    locks.push_back(RunLock::acquire(RunLock::lock_file_of(store_path), fmt::format("the study {}", store_path)));
  // The store's own guard too (store_guard.hpp): a run whose lock file was deleted still holds the study. Checked
  // before anything is written or removed, taken again on the file Study::attach leaves (it may be a new one).
  std::optional<detail::StoreGuard> store_guard;
  if (!is_database_url(store_path))
    store_guard.emplace(detail::StoreGuard::take(store_path, fmt::format("the study {}", store_path),
                                                 RunLock::lock_file_of(store_path)));
  const std::string folder_store = study.output + "/study.db";
  if (!own_store && !same_file(folder_store, store_path))
    locks.push_back(RunLock::acquire(RunLock::lock_file_of(folder_store), fmt::format("the run folder {}", study.output)));
  if (!ov.resume && (own_store || ov.overwrite) && std::filesystem::exists(store_path)) {
    if (!ov.overwrite) refuse_to_replace(study.output, store_path, ov, study_identity(study), study.budget);
    else refuse_to_overwrite_live_workers(store_path);
    remove_store_files(store_path);  // a fresh run replaces a study without trials, or with --overwrite
  } else if (!ov.resume && ov.overwrite) {
    remove_store_files(store_path);  // no study file, but maybe its leftover -wal, which creating would refuse
  }
  // Resumed by a later varbo: the stored configuration is the one given; what this version resolves it to is
  // recorded (a warning names the first difference) instead of refusing the study as another configuration's.
  if (ov.resume) study_detail::adopt_current_resolution(store_path, study, registry);
  Study st = Study::attach(store_path, study, registry);
  if (store_guard && !store_guard->guards(store_path)) {
    *store_guard = detail::StoreGuard();  // an OFD lock of another open file of the same inode would conflict
    *store_guard = detail::StoreGuard::take(store_path, fmt::format("the study {}", store_path),
                                            RunLock::lock_file_of(store_path));
  }
  made_folders.keep();
  st.set_meta(store_key::kOutput, std::filesystem::absolute(study.output).string());
  Task& task = st.task();
  const Domain& shown = st.domain();
  const Domain domain = shown;
  // Trials a killed session of this run left pending: their results will never come, and the replay suggests
  // them again. Only trials of earlier run sessions are touched (this run holds the run lock, so they are dead,
  // on any host), so a study shared with live external workers keeps their pending trials.
  // Only a run's own trials, that is: each run session records its worker id in the study (`run_worker/ID`),
  // and a trial handed out by `varbo suggest` (whose process has ended too, by design) is someone's experiment
  // in progress — abandoning it ran its point again and turned the operator's result into a late one (red team,
  // session 23). Studies from before this record (no `run_workers` key) keep the earlier rule.
  const std::string me = default_worker_name();
  const bool runs_recorded = st.meta("run_workers").has_value();
  std::set<std::int64_t> leftovers;  // decided before the transaction (which may run its body again)
  std::vector<std::int64_t> others_pending;
  for (const TrialRecord& t : st.store().pending_trials()) {
    // A process of this host that is gone (ESRCH only: EPERM is another user's live process, a colleague's Python
    // Study on a shared machine, whose trial was abandoned and ran twice; red team, session 29), or this very one.
    const bool dead_here = worker_process_gone(t.worker) ||
                           worker_host_pid(t.worker) == std::pair<std::string, long>(host_id(), getpid());
    const bool recorded_run = runs_recorded && st.meta("run_worker/" + t.worker).has_value();
    // A recorded run session's trial is a dead session's, on whatever host it ran: this run holds the study's run
    // lock, which a live run would hold (a run killed on host A and resumed on host B left its trial pending
    // forever; red team, session 25). Without the record, only a process of this host known to be gone.
    if (recorded_run || (!runs_recorded && dead_here)) leftovers.insert(t.id);
    else others_pending.push_back(t.id);
  }
  if (is_database_url(store_path)) {
    // The lock was free, but a server restart frees it while its run lives on: a run session whose heartbeat is
    // recent still runs its trial (re-audit, session 49: a second run took the study after a restart, abandoned
    // the live run's trial and ran its θ beside it). Its lock comes back at its next trial.
    const double timeout = st.config().heartbeat_timeout > 0 ? st.config().heartbeat_timeout : 60.0;
    for (const std::int64_t id : leftovers)
      if (const auto t = st.store().trial(id); t && run_heartbeat_recent(st.store(), t->worker, timeout + command_stop_seconds(st.config().task)))
        throw InputError(fmt::format("the study {} is in use by another run ({}, running trial {}; its heartbeat is "
                                     "recent though its run lock's server session ended, as a server restart ends "
                                     "it); wait for it to end or stop it, or try again in {:.0f} s if it is gone",
                                     study_tag(store_path), printable(t->worker), id,
                                     timeout + command_stop_seconds(st.config().task)));
  }
  const std::vector<std::int64_t> interrupted = st.abandon_where(
      [&](const TrialRecord& t) { return leftovers.count(t.id) > 0; },
      "interrupted: the run stopped before the result was recorded");
  st.set_meta("run_workers", "1");
  st.set_meta("run_worker/" + me, detail::utc_timestamp());
  // On a database study the run lock is a server session, which a server restart ends while this run lives on:
  // a heartbeat tells workers that this run's pending trial is still being run (run_liveness.hpp).
  std::unique_ptr<BackgroundTicker> run_heartbeats;
  if (is_database_url(store_path)) {
    note_run_lock_taken(st.store(), me);
    const double timeout = st.config().heartbeat_timeout;
    run_heartbeats = start_run_heartbeats(store_path, me, timeout > 0 ? std::max(0.05, timeout / 4) : 10.0);
  }
  if (!others_pending.empty()) {
    std::string ids;
    for (std::size_t i = 0; i < others_pending.size() && i < 10; ++i) ids += (i ? ", " : "") + std::to_string(others_pending[i]);
    if (others_pending.size() > 10) ids += fmt::format(" and {} more", others_pending.size() - 10);
    log_warn("{}: trial(s) {} are pending, asked by `varbo suggest`, a worker or another program; they are left to "
             "it and count against the budget until their results come (`varbo abandon {} --id ID` gives one up)",
             store_path, ids, shell_word(store_path));
  }

  const std::optional<Optimum> optimum = admissible_optimum(task, st.space(), study.task.info->name);
  RunWriter writer(study.output, study, shown, task.component_names(), optimum.has_value(), st.space(),
                   study_detail::stored_plugin_paths(st.store(), store_path));
  writer.set_study(study_tag(store_path));
  // A resumed run continues its log; a fresh one (a new folder, or --overwrite) starts it: the old study's lines
  // stayed above the new one's, two "run" headers of two studies in one file (red team, session 25).
  // A study continued with `--study FILE` (it holds trials already) is not a fresh run: its log was deleted (red
  // team, session 28).
  if (!ov.resume && st.store().trials().empty()) {
    std::error_code ec;
    std::filesystem::remove(study.output + "/log.txt", ec);
  }
  set_log_file(study.output + "/log.txt");
  log_info("run {}: task {}, algorithm {}, budget {}, seed {}, threads {}", study.output, study.task.info->name,
           study.algorithm.info->name, study.budget, study.seed,
           study.threads > 0 ? study.threads : hardware_threads());

  RunSummary summary;
  if (study.algorithm.info && study.algorithm.info->name == "bo")
    summary.recommendation_rule = study.algorithm.options.str("recommendation");
  summary.output = study.output;
  double best_noiseless = std::numeric_limits<double>::infinity();
  const Rng task_rng = Rng(study.seed).stream(0x7a5c);  // task noise: one stream per trial index
  Index last_snapshot = -1;

  // The recommendation after the latest tell, and its noise-free regret where the task can tell it.
  // A resumed run's algorithm is rebuilt from the store first (before, a finished run resumed had none, and its
  // summary.json lost the recommended θ and its regret).
  bool bad_recommendation_said = false;
  Index failures_in_a_row = 0, timeouts_in_a_row = 0;
  // The unit-cube box of the current streak's failed θ, and the θ of its last failure: a streak at one place is a
  // failure region the algorithm keeps to (rssgd started inside one never moves), not a rig that is down.
  Vec streak_low, streak_high, streak_theta;
  std::vector<std::int64_t> streak_ids;  // the failed trials in a row (stop_after_failures names them for retract)
  std::string last_failure;
  // The regret figures only: a task's noise-free cost that throws (third-party code) leaves them out, said once,
  // instead of ending the run with "internal error" and the evaluated trial left pending (red team, session 23).
  bool noiseless_failed = false;
  auto noiseless = [&](const Vec& theta) -> std::optional<double> {
    if (noiseless_failed) return std::nullopt;
    try {
      return task.noiseless_cost(theta);
    } catch (const std::exception& e) {
      noiseless_failed = true;
      log_warn("task '{}'{}: its noise-free cost (for the regret figures) failed: {}; the run goes on without them",
               study.task.info->full_name(),
               study.task.info->library.empty() ? std::string() : " (from " + study.task.info->library + ")",
               safe_text(e.what(), 300));
    } catch (...) {
      noiseless_failed = true;
      log_warn("task '{}': its noise-free cost threw something that is not a std::exception; the run goes on "
               "without the regret figures",
               study.task.info->full_name());
    }
    return std::nullopt;
  };
  // The recommendation and the model snapshot are extras of a result: a throw from the algorithm's (perhaps a
  // plugin's) code there rolled the result's commit back — the trial pending, exit 3, and the same on every
  // resume (red team, session 28). Said once per kind; the result is recorded without it. A lost connection is
  // still the store's to retry.
  std::set<std::string> extra_failure_said;
  auto extra = [&](const char* what, const auto& f) {
    const std::string why = detail::what_it_threw<StoreConnectionError>(f);
    if (why.empty()) return;
    if (!extra_failure_said.insert(what).second) return log_debug("algorithm '{}': {} failed: {}", study.algorithm.info->full_name(), what, why);
    log_warn("algorithm '{}': {} failed ({}); the trial's result is recorded without it (said once)",
             study.algorithm.info->full_name(), what, why);
  };
  std::unordered_map<std::string, Vec> theta_at_point;  // complete trials: exact unit point → θ (account())
  auto point_key = [](const Vec& x) {
    return std::string(reinterpret_cast<const char*>(x.data()), static_cast<std::size_t>(x.size()) * sizeof(double));
  };
  // Set once another writer's result (a `varbo worker`, `observe`) has been accounted: the live algorithm has not
  // been told it until its next ask, so its recommendation lagged — a run sharing its study with a worker wrote
  // trial 9's θ (cost 0.0117) to summary.json beside trial 11's 0.000998 (audit, session 48). The study's own
  // recommendation brings the algorithm up to date first.
  bool others_accounted = false;
  auto recommend_unguarded = [&]() {
    const Algorithm* a = st.algorithm();
    if (!a || others_accounted) {
      const std::optional<Vec> theta = st.recommendation();
      if (!theta) return;
      summary.recommended_theta = *theta;
    } else {
      const std::optional<Vec> r = a->recommendation();
      if (!r) return;
      const Index d = st.space() ? st.space()->encoded_dim() : domain.box.dim();
      if (!study_detail::usable_recommendation(*r, d, study.algorithm.info->full_name(), !bad_recommendation_said)) {
        bad_recommendation_said = true;  // said once per run: recommend() runs after every trial
        return;
      }
      // The evaluated trial's own θ when the recommendation is one (decoding gave 3.0999999999999996 for 3.1): looked
      // up by the point's exact coordinates among the complete trials this run has accounted (reading every trial
      // after every trial was quadratic in a long run).
      const Vec x = st.space() ? st.space()->admissible(*r) : Vec(Box::unit(r->size()).clamp(*r));
      const auto at = theta_at_point.find(point_key(x));
      summary.recommended_theta =
          at != theta_at_point.end() ? at->second : study_detail::recommended_theta(*r, {}, st.space().get(), domain.box);
    }
    if (!optimum) return;
    const std::optional<double> v = noiseless(*summary.recommended_theta);
    if (v && std::isfinite(*v)) summary.regret_recommended = *v - optimum->cost;
  };
  auto recommend = [&]() { extra("its recommendation", recommend_unguarded); };
  // Per-row regret of the recommendation, kept in the store so a resumed run rewrites trials.csv exactly.
  auto regret_key = [](Index row) { return fmt::format("regret_recommended/{}", row); };

  std::int64_t best_id = -1;
  auto account = [&](TrialRow& row) {
    const TrialRecord& t = row.trial;
    if (!row.ok()) {
      ++summary.failed;
    } else {
      // Ties to the lowest id, as the store's best() (status, Python, the dashboard): the run took the first to
      // finish, and with several workers and coarse costs the views named different trials (red team, session 30).
      if (!summary.best_theta || t.cost < summary.best_cost || (t.cost == summary.best_cost && t.id < best_id)) {
        summary.best_cost = t.cost;
        summary.best_theta = t.theta;
        best_id = t.id;
      }
      // A trial recorded by hand (observe, a worker, tell_point) has no noise-free cost stored: the task's, not
      // its measured one (which made this "oracle" regret −100 with `observe new -100`).
      double nl = t.noiseless_cost;
      if (std::isnan(nl)) {
        const std::optional<double> v = optimum ? noiseless(t.theta) : std::nullopt;
        nl = v && std::isfinite(*v) ? *v : t.cost;
      }
      best_noiseless = std::min(best_noiseless, nl);
      if (t.state == TrialState::Complete) theta_at_point.emplace(point_key(t.x), t.theta);
    }
    ++summary.evaluations;
    if (optimum && std::isfinite(best_noiseless)) {
      summary.regret_best_observed = best_noiseless - optimum->cost;
      row.regret_best_observed = *summary.regret_best_observed;
    }
  };

  // Results recorded by other writers of the study while this run drives it (`varbo worker`, `varbo observe`, a
  // Python tell): rows of trials.csv and part of the summary in the order they finished, as a resumed run writes
  // them. Before, the summary and trials.csv held this run's own trials only — the best result of the study could
  // be missing from both (red team, session 23).
  std::int64_t accounted_seq = 0;  // finish_seq of the next trial to account
  auto catch_up = [&](std::int64_t before_seq) {
    Index n = 0;
    for (const TrialRecord& t : st.store().finished_since(accounted_seq)) {
      if (t.finish_seq >= before_seq) break;
      TrialRow other;
      other.index = summary.evaluations;
      other.trial = t;
      account(other);
      writer.trial(other);
      accounted_seq = t.finish_seq + 1;
      others_accounted = true;
      ++n;
    }
    return n;
  };

  // Resume: rewrite the run folder from the store (it may lag behind the store by the trial being written).
  {
    std::vector<TrialRecord> done;
    for (const auto& t : st.trials())
      if (t.finished()) done.push_back(t);
    std::sort(done.begin(), done.end(),
              [](const TrialRecord& a, const TrialRecord& b) { return a.finish_seq < b.finish_seq; });
    for (const auto& t : done) {
      TrialRow row;
      row.index = summary.evaluations;
      row.trial = t;
      account(row);
      if (optimum)
        if (auto v = st.meta(regret_key(row.index))) row.regret_recommended = strtod_c(v->c_str(), nullptr);
      writer.trial(row);
    }
    if (!done.empty()) recommend();
    for (const auto& s : st.model_snapshots()) {
      writer.model(s.snapshot);
      last_snapshot = s.snapshot.iteration;
    }
    accounted_seq = static_cast<std::int64_t>(done.size());
    writer.publish();
    if (!done.empty())
      log_info("resuming {}: {} finished trials read from {}{}", study.output, done.size(), store_path,
               interrupted.empty() ? std::string() : fmt::format(", {} interrupted trial(s) suggested again",
                                                                 interrupted.size()));
  }

  // A stop signal (install_interrupt_handlers, `varbo run`) ends the loop between trials, or during one: an
  // external command is then killed with its whole process tree, and its trial, which has no result, is
  // recorded abandoned (so --resume suggests it again) rather than failed.
  int stop_signal = 0;
  auto stop_requested = [&ov] {
    const int s = interrupt_signal();
    return s != 0 || !ov.stop_signal ? s : ov.stop_signal();
  };
  // A database study outlives a server restart or a network cut: what a lost connection cut short is retried
  // (store_retry.hpp), and the one-writer lock, whose session the server has then ended, is taken again. Before,
  // the first lost connection ended the run, and the trial being recorded was left pending.
  const bool database_study = database_lock.has_value();
  auto retake_lock = [&] {
    // (An attempt that failed to take it again left it empty: the next one tries again.)
    if (!database_study || (database_lock && database_lock->held())) return;
    database_lock.reset();
    database_lock.emplace(DatabaseRunLock::acquire(store_path));  // another run took it meanwhile: an InputError
    note_run_lock_taken(st.store(), me);
    log_warn("run {}: the database session holding the study's run lock had ended; the lock is taken again",
             study.output);
  };
  auto reconnecting = [&](auto&& f) {
    return retry_while_unreachable(ov.reconnect_seconds, "run " + study.output, [&] { return stop_requested() != 0; },
                                   f, retake_lock);
  };
  while (summary.evaluations < study.budget && !(stop_signal = stop_requested())) {
    if (database_study) reconnecting([&] { retake_lock(); });
    bool ask_retried = false;
    std::vector<TrialRecord> asked = reconnecting([&] {
      if (ask_retried) {
        // A suggestion whose COMMIT was cut may have landed: this run is the study's one writer, so a trial of its
        // own pending now is that one (it would hold a budget slot for good), and is abandoned before asking again.
        st.abandon_where([&](const TrialRecord& p) { return p.worker == me; },
                         "suggested while the connection to the database server was lost");
      }
      ask_retried = true;
      return st.ask(1);
    });
    if (asked.empty()) {
      const std::size_t pending = st.store().pending_trials().size();
      if (pending > 0)
        log_info("nothing more to suggest: {} pending trial(s) of other processes hold the rest of the budget; "
                 "stopping after {} evaluations (their results, when recorded, are part of the study)",
                 pending, summary.evaluations);
      else  // a warning: the run ends short of its budget (red team, session 31: said at info level, unseen)
        log_warn("algorithm '{}' has nothing more to suggest (it has finished); stopping after {} of {} evaluations",
                 study.algorithm.info ? study.algorithm.info->name : std::string("?"), summary.evaluations,
                 study.budget);
      break;
    }
    const TrialRecord& t = asked.front();
    const Index index = summary.evaluations;
    Rng trng = task_rng.stream(static_cast<std::uint64_t>(index));
    Evaluation evaluation;
    bool stopped_by_signal = false;
    const auto t0 = std::chrono::steady_clock::now();
    if (auto* aware = dynamic_cast<TrialAware*>(&task)) aware->set_next_trial(static_cast<long>(index), static_cast<long>(t.id));
    try {
      evaluation = task.evaluate(t.theta, trng);
    } catch (const TaskSetupError& e) {
      // Not a result of θ: the trial is abandoned (suggested again by --resume), the run stops (errors.hpp).
      retry_while_unreachable(ov.reconnect_seconds, "run " + study.output, {}, [&] {
        return st.abandon_where([&](const TrialRecord& p) { return p.id == t.id; }, "the task could not run");
      });
      // Kept a TaskSetupError: an embedding host catches it to reconnect the robot (it became an InputError).
      throw TaskSetupError(fmt::format("trial {}: {}; the trial is abandoned, not failed (`varbo run --resume {}` "
                                       "suggests it again once the task can run)",
                                       trial_label(index, t.id), e.what(), resume_target));
    } catch (const Interrupted& e) {  // stopped by the signal: no result (task.hpp)
      evaluation = Evaluation{};
      evaluation.ok = false;
      evaluation.error = e.what();
      stopped_by_signal = true;
    } catch (const std::exception& e) {
      evaluation = Evaluation{};
      evaluation.ok = false;
      evaluation.error = e.what();
    } catch (const abi::__forced_unwind&) {
      // A thread ended by pthread_exit or cancellation (a Python daemon thread at the program's end) unwinds
      // through here; swallowing the unwind aborts the process ("FATAL: exception not rethrown").
      throw;
    } catch (...) {  // task.hpp: an exception from evaluate() is a failed trial, never a crash (`throw 7` was one)
      evaluation = Evaluation{};
      evaluation.ok = false;
      evaluation.error = "the task threw something that is not a std::exception";
    }
    const double evaluation_seconds = seconds_since(t0);
    // Only a trial the signal cut short is abandoned: one that had timed out when Ctrl-C came during its grace was
    // recorded abandoned, and --resume ran the θ that hung again (red team, session 34).
    if ((stop_signal = stop_requested()) != 0 && stopped_by_signal) {
      const std::string reason = fmt::format("interrupted by {}", signal_name(stop_signal));
      retry_while_unreachable(ov.reconnect_seconds, "run " + study.output, {}, [&] {
        return st.abandon_where([&](const TrialRecord& p) { return p.id == t.id; }, reason);
      });
      // The evaluation's error is most often the reason itself: said once ("interrupted by SIGTERM (interrupted by
      // SIGTERM)", red team, session 37).
      const std::string detail = safe_text(evaluation.error, 300);
      log_warn("trial {} abandoned: {}{}", trial_label(index, t.id), reason,
               detail.empty() || detail == reason ? "" : " (" + detail + ")");
      break;
    }
    if (!evaluation.ok) evaluation.error = study_detail::stored_reason(evaluation.error);
    // "trial 0 failed: " and an empty error column said nothing (red team, session 23).
    if (!evaluation.ok && evaluation.error.empty()) evaluation.error = "failed (the task gave no reason)";
    // A task that knows its noise-free cost (Task::noiseless_cost) but leaves the evaluation's field empty:
    // regret_best_observed fell back to the noisy cost and went negative (two_minima_1d: −0.073).
    if (optimum && evaluation.ok && std::isnan(evaluation.noiseless_cost))  // only for the regret
      if (const std::optional<double> v = noiseless(t.theta); v && std::isfinite(*v))
        evaluation.noiseless_cost = *v;
    if (evaluation.ok && !std::isfinite(evaluation.cost)) {
      evaluation.ok = false;
      evaluation.error = fmt::format("non-finite cost {}", evaluation.cost);
    }
    if (!evaluation.ok) log_warn("trial {} failed: {}", trial_label(index, t.id), evaluation.error);
    // The result and the model snapshot of this iteration are committed together; the row is the stored trial.
    // The snapshot is read after the algorithm has been told the result, so an algorithm that updates in tell()
    // (rssgd's step) shows the update this trial caused, not the previous one.
    std::optional<ModelSnapshot> snap;
    bool new_snapshot = false;
    TrialRow row;
    row.index = index;
    // If this commit fails (a full disk: "database or disk is full"), the trial stays pending in the store and
    // its result — perhaps an hour of robot time — would be gone with the error. Say it, with the command that
    // records it once the cause is fixed.
    auto say_result_lost = [&](const std::exception& e) {
      // Quoted: a PostgreSQL URL's '&' would send the pasted command to the background.
      const std::string observe =
          evaluation.ok ? fmt::format("varbo observe {} {} {}", shell_word(store_path), t.id, exact(evaluation.cost))
                        : fmt::format("varbo fail {} {} --reason 'recorded by hand'", shell_word(store_path), t.id);
      std::string parts;
      for (const auto& [name, value] : evaluation.components) parts += fmt::format(" --component {}={}", name, exact(value));
      // Where the study file was replaced, the file of that name is another study: no command to record it there
      // (audit, session 45: a worker's suggestion put its cost on another study's trial of the same id).
      if (dynamic_cast<const StudyFileChangedError*>(&e) != nullptr) {
        log_warn("trial {} ({}) at θ = {} was evaluated but its result could not be recorded: {}; it belongs to the "
                 "study that was at that path when this run opened it, not to the file there now",
                 t.id, evaluation.ok ? "cost " + exact(evaluation.cost) : "failed",
                 st.space() && t.theta.allFinite() ? st.space()->params(t.theta).to_json() : fmt_vec(t.theta),
                 safe_text(e.what(), 300));
        return;
      }
      log_warn("trial {} ({}) was evaluated but its result could not be recorded: {}; it is pending in the store. "
                "Once the cause is fixed, record it with: {}{} (a --resume instead suggests it again)",
                t.id, evaluation.ok ? "cost " + exact(evaluation.cost) : "failed", safe_text(e.what(), 300), observe,
                evaluation.ok ? parts : std::string());
    };
    try {
    reconnecting([&] {
    try {
    st.transaction([&] {
      row.trial = st.record(t.id, evaluation, evaluation_seconds);
      // Known to the recommendation made below, before account() (which comes after the others' results).
      if (row.trial.state == TrialState::Complete) theta_at_point.emplace(point_key(row.trial.x), row.trial.theta);
      if (const Algorithm* a = st.algorithm()) extra("its model snapshot", [&] { snap = a->snapshot(); });
      new_snapshot = snap && snap->iteration != last_snapshot;
      if (new_snapshot) st.add_model_snapshot(StoredSnapshot{index + 1, *snap});
      summary.regret_recommended.reset();
      recommend();
      // Keyed by the row the trial takes (its place in the order of results), as a resumed run reads it back.
      if (summary.regret_recommended)
        st.set_meta(regret_key(row.trial.finish_seq >= 0 ? static_cast<Index>(row.trial.finish_seq) : index),
                    exact(*summary.regret_recommended));
    });
    } catch (const StoreConnectionError&) {
      throw;  // retried
    } catch (const InputError&) {
      // After a retry: a COMMIT cut by the lost connection may have landed (the trial, its snapshot and regret
      // together); then the trial is finished with this result and there is nothing left to write.
      const auto stored = st.store().trial(t.id);
      const bool landed = stored && stored->finish_seq >= 0 &&
                          (evaluation.ok ? stored->state == TrialState::Complete && stored->cost == evaluation.cost
                                         : stored->state == TrialState::Failed);
      const bool by_another = !landed && stored && stored->finish_seq >= 0 &&
                              (stored->state == TrialState::Complete || stored->state == TrialState::Failed);
      if (!landed && !by_another) throw;
      if (by_another)
        // An operator's `varbo fail STUDY ID --reason "robot fell"` (or `observe`) while the trial ran: theirs
        // stands, as with `varbo worker`; the run exited 2 here and told them to record the trial again (red
        // team, session 28).
        log_warn("trial {}: already recorded as {} by another process while it ran; that record stands, this "
                 "run's result ({}) is not stored",
                 t.id, stored->state == TrialState::Complete ? "complete, cost " + exact(stored->cost) : "failed",
                 evaluation.ok ? "cost " + exact(evaluation.cost) : "failed");
      row.trial = *stored;
      if (row.trial.state == TrialState::Complete) theta_at_point.emplace(point_key(row.trial.x), row.trial.theta);
      summary.regret_recommended.reset();
      recommend();
    }
    });
    } catch (const std::exception& e) {
      say_result_lost(e);
      throw;
    }
    if (summary.regret_recommended) row.regret_recommended = *summary.regret_recommended;
    catch_up(row.trial.finish_seq);  // others' results that came first
    row.index = summary.evaluations;
    account(row);
    writer.trial(row);
    accounted_seq = std::max(accounted_seq, row.trial.finish_seq + 1);
    failures_in_a_row = row.ok() ? 0 : failures_in_a_row + 1;
    if (row.ok()) streak_ids.clear();
    else streak_ids.push_back(row.trial.id);
    if (!row.ok() && row.trial.x.size() > 0) {
      if (failures_in_a_row == 1 || streak_low.size() != row.trial.x.size()) {
        streak_low = streak_high = row.trial.x;
      } else {
        streak_low = streak_low.cwiseMin(row.trial.x);
        streak_high = streak_high.cwiseMax(row.trial.x);
      }
      streak_theta = row.trial.theta;
    }
    // The external task's timeout message: a streak of those is a timeout too short, not a rig that is down.
    timeouts_in_a_row = row.ok() ? 0 : timeouts_in_a_row + (row.trial.error.find("timed out after") != std::string::npos);
    if (!row.ok()) last_failure = row.trial.error;
    if (ov.progress) {
      std::string line = fmt::format("[{:>4}/{}] {:<10} cost {:>12.6g}  best {:>12.6g}", summary.evaluations,
                                     study.budget, t.phase, row.ok() ? row.trial.cost : NAN,
                                     summary.best_theta ? summary.best_cost : NAN);
      if (summary.regret_recommended) line += fmt::format("  regret(rec) {:.2e}", *summary.regret_recommended);
      line += fmt::format("  fit {:.3f}s acq {:.3f}s eval {:.3f}s", t.fit_seconds, t.acquisition_seconds,
                          evaluation_seconds);
      std::fprintf(stderr, "%s\n", line.c_str());
    }
    if (new_snapshot) {
      writer.model(*snap);
      last_snapshot = snap->iteration;
    }
    summary.seconds = seconds_since(t_start);
    writer.summary(summary, shown, optimum);
    if (ov.on_trial && !ov.on_trial(row.trial)) break;
    if (study.stop_after_failures > 0 && failures_in_a_row >= study.stop_after_failures &&
        summary.evaluations < study.budget) {
      const std::string why = fmt::format(
          "run {} stopped after {} failed trials in a row (stop_after_failures: {}), the last: {}; every trial is "
          "recorded. {}, then continue with: {}{}",
          study.output, failures_in_a_row, study.stop_after_failures, safe_text(last_failure, 300),
          // Every one timed out: `--resume` keeps the stored timeout and times out again (red team, session 30).
          timeouts_in_a_row == failures_in_a_row && study.task.info && study.task.info->name == "external"
              ? fmt::format("Every one timed out: if a trial needs longer, continue with a longer timeout: varbo "
                            "worker {} --timeout SECONDS (the study's command); else check the setup",
                            shell_word(store_path))
              : streak_low.size() > 0 && (streak_high - streak_low).maxCoeff() <= 0.25
                  // red team, session 46: rssgd started inside a failure region fails there until this stop, and a
                  // resume fails 10 times more; the message blamed the rig.
                  ? fmt::format("The {} failed θ lie within {:.0f} % of the domain of one another (the last: "
                                "{}): if the setup works, the search is stuck in a failure region — an algorithm that "
                                "moves only on successes (rssgd, cma_es) needs a start point outside it (`start:`, "
                                "`x0:`); else check the setup (is the robot powered, the E-stop released?)",
                                failures_in_a_row, std::ceil(100 * (streak_high - streak_low).maxCoeff()),
                                fmt_vec(streak_theta))
                  : std::string("Check the setup (is the robot powered, the E-stop released?)"),
          fmt::format(fmt::runtime(ov.resume_hint), resume_target),
          // The command is part of the study's identity (a resumed run runs the stored one): a wrong command is
          // replaced by a worker's, which runs the same study (red team, session 23).
          study.task.info && study.task.info->name == "external"
              ? fmt::format("; if the command itself is wrong, continue with a corrected one: varbo worker {} "
                            "--command 'CORRECTED COMMAND'",
                            shell_word(store_path))
              : std::string());
      // Those failures teach bo's failure model that their θ fail: after an outage that keeps good regions closed
      // (audit, session 48: 10⁵× worse at the same budget). Said, with the command that takes them back.
      std::string ids;
      for (const auto id : streak_ids) ids += fmt::format(" --id {}", id);
      const std::string retract =
          ov.resume_hint.find("varbo run --resume") != std::string::npos && !streak_ids.empty()
              ? fmt::format(". If the rig, not θ, failed these trials, take them back before resuming, or bo keeps "
                            "their neighbourhoods closed: varbo retract {}{}",
                            shell_word(store_path), ids)
              : std::string();
      throw InputError(why + retract);
    }
  }
  // Results that came in after this run's last one: the recommendation then sees them too.
  if (catch_up(std::numeric_limits<std::int64_t>::max()) > 0 || others_accounted || !summary.recommended_theta)
    recommend();
  if (const SearchSpace* space = st.space().get()) {
    if (summary.best_theta) summary.best_params = params_text(*space, *summary.best_theta);
    if (summary.recommended_theta) summary.recommended_params = params_text(*space, *summary.recommended_theta);
  }
  if (st.replay_mismatches() > 0)
    log_warn("{} replayed trial(s) did not reproduce their stored point: this run is not bit-for-bit the run that "
             "would not have stopped",
             st.replay_mismatches());
  summary.seconds = seconds_since(t_start);
  writer.summary(summary, shown, optimum);
  if (const std::vector<std::string> stale = writer.stale_files(); !stale.empty())
    log_warn("run {}: {} not up to date (writing failed: see the first warning); the study file holds every trial "
             "— `varbo status {}` shows the best, `varbo export {}` writes the table",
             study.output, fmt::join(stale, " and "), shell_word(store_path),
             shell_word(store_path));
  if (stop_signal) {
    log_warn("run {} stopped by {} after {} evaluations; continue it with: {}", study.output,
             signal_name(stop_signal), summary.evaluations, fmt::format(fmt::runtime(ov.resume_hint), resume_target));
    set_log_file("");
    throw Interrupted(stop_signal);
  }
  set_log_file("");
  return summary;
}
}  // namespace

RunSummary run_study_file(const std::string& config_file, const RunOverrides& overrides) {
  ConfigNode root = ConfigNode::load_file(config_file);
  Registry registry;
  PluginLoader loader(registry);
  loader.load_default(plugin_paths_of(root));
  StudyConfig study = parse_study(root, registry);
  return run_study(study, registry, overrides);
}

}  // namespace varbo

namespace varbo {

RunSummary resume_study(const std::string& target, const RunOverrides& overrides) {
  std::string store_path = target;
  const bool url = is_database_url(target);
  if (!url && std::filesystem::is_directory(target))
    store_path = (std::filesystem::path(target) / "study.db").string();
  if (!url && !std::filesystem::exists(store_path)) {
    // A run on a study kept elsewhere (`--study s.db`): its folder's summary.json names the study; said, with the
    // command that resumes it (audit, session 44: "nothing to resume" only).
    if (std::filesystem::is_directory(target)) {
      const std::string summary = (std::filesystem::path(target) / "summary.json").string();
      if (absent_or_regular_file(summary)) {
        std::ifstream in(summary);
        const nlohmann::json j = in ? nlohmann::json::parse(in, nullptr, false) : nlohmann::json();
        if (!j.is_discarded() && j.is_object() && j.contains("study") && j["study"].is_string() &&
            (is_database_url(j["study"].get<std::string>()) || std::filesystem::exists(j["study"].get<std::string>())))
          throw InputError(fmt::format("{}: the folder holds no study.db: its run's study is {} (summary.json); "
                                       "resume with `varbo run --resume {}`",
                                       target, j["study"].get<std::string>(),
                                       shell_word(j["study"].get<std::string>())));
      }
    }
    throw InputError(fmt::format("{}: nothing to resume (expected a run folder holding study.db, or a study file)",
                                 target));
  }
  std::unique_ptr<StudyStore> store = open_store(store_path);
  const auto text = store->meta(store_key::kConfig);
  if (!text) throw InputError(fmt::format("{}: the study store holds no configuration", store_path));
  const std::vector<std::string> paths = study_detail::stored_plugin_paths(*store, store_path);
  if (overrides.budget && *overrides.budget < static_cast<Index>(store->next_finish_seq()))
    // Accepted before: `status` then showed "budget 5, 0 left" on a study of 33 trials (red team, session 26).
    throw InputError(fmt::format("--budget {}: the study {} has finished {} trials already; give at least {}",
                                 *overrides.budget, store_path, store->next_finish_seq(), store->next_finish_seq()));
  RunOverrides ov = overrides;
  if (!url && ov.output && std::filesystem::is_directory(target) && !same_file(*ov.output, target))
    // The run folder holds the study and its outputs together: writing the outputs elsewhere split the run (the
    // trials went to TARGET/study.db, trials.csv and summary.json to the other folder, which then had nothing to
    // resume).
    throw InputError(fmt::format("--resume {}: continues the run in its own folder; -o {} would split it (the study "
                                 "stays in {}). Leave -o out, or copy the run folder first and resume the copy",
                                 target, *ov.output, target));
  if (!ov.output) {
    // Where the run folder is now: a moved or copied folder is continued in place, never at the path stored
    // when it was created (that may be the original, still in use, or gone).
    namespace fs = std::filesystem;
    const fs::path parent = fs::absolute(store_path).parent_path();
    if (url) ov.output = store->meta(store_key::kOutput).value_or("runs/resumed");
    else if (fs::is_directory(target)) ov.output = target;
    else if (this_studys_folder(parent.string(), store_path, *store))
      ov.output = parent.string();
    else if (auto out = store->meta(store_key::kOutput)) ov.output = *out;  // a study file kept apart (--study)
    else if ((fs::exists(parent / "config.resolved.yaml") || fs::exists(parent / "trials.csv")) &&
             !other_studys_folder(parent.string(), store_path))  // (another study's folder: refused by run_study)
      // A study made by `varbo study create` beside files of the user's own (a trials.csv of hand-tuned rows): the
      // run took the folder as its run folder and replaced them in silence (red team, session 28).
      throw InputError(fmt::format("--resume {}: the study has no run folder yet, and the folder it is in holds a "
                                   "trials.csv or config.resolved.yaml this study did not write; give the run "
                                   "folder with -o DIR",
                                   target));
    else ov.output = parent.string();
  }
  store.reset();
  // `--resume RUN --study OTHER` continued RUN's own study and left OTHER untouched, in silence (fuzzing, session 27).
  std::error_code same_ec;
  if (ov.store && !ov.store->empty() && *ov.store != store_path &&
      !std::filesystem::equivalent(*ov.store, store_path, same_ec))
    throw InputError(fmt::format("--study {} conflicts with --resume {}: a resumed run continues its own study ({}); "
                                 "to continue the study file, resume it: --resume {}",
                                 *ov.store, target, store_path, *ov.store));
  ov.store = store_path;
  ov.resume = true;
  ConfigNode root = ConfigNode::parse(*text, store_path + ConfigNode::kStoredSuffix);
  Registry registry;
  PluginLoader loader(registry);
  loader.load_default(paths);
  StudyConfig study = study_detail::parse_stored_study(root, registry, store_path);
  return run_study(study, registry, ov);
}

}  // namespace varbo
