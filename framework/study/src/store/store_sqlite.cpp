// The SQLite study store: one file, WAL journal (readers never block the writer), a 10 s busy timeout plus
// retries, and BEGIN IMMEDIATE transactions so that concurrent suggest/observe processes serialize their
// read-modify-write steps and never lose an observation.
#include <fmt/format.h>
#include <sqlite3.h>

#include <sys/statvfs.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <chrono>
#include <cstring>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "varbo/errors.hpp"
#include "varbo/interrupt.hpp"
#include "varbo/log.hpp"
#include "varbo/store.hpp"
#include "varbo/text.hpp"
#include "sqlite_side_files.hpp"
#include "store_codec.hpp"

namespace varbo {

namespace {

using namespace store_codec;

constexpr const char* kFormat = "varbo-study";
constexpr int kBusyTimeoutMs = 10000;
constexpr int kInterruptedWaitMs = 2000;  // after a stop signal (busy_wait)
constexpr int kBeginAttempts = 60;  // × up to 10 s of busy waiting each: a writer may hold the lock for a fit

bool on_read_only_filesystem(const std::string& path) {
  struct statvfs fs{};
  return statvfs(path.c_str(), &fs) == 0 && (fs.f_flag & ST_RDONLY) != 0;
}

/// Why this process cannot change the study file at `path` ("" when it can): a read-only file system, or no
/// permission to write the file or, when its -wal and -shm must be made, its folder. Such a study is still read
/// (status, export, verify): a study owned by another user was refused by every command as "attempt to write a
/// readonly database" (red team, session 25).
std::string read_only_reason(const std::string& path) {
  if (on_read_only_filesystem(path)) return "on a read-only file system";
  if (access(path.c_str(), W_OK) != 0)
    return fmt::format("not writable by this user ({}: {})", path, std::strerror(errno));
  const std::string folder = std::filesystem::absolute(path).parent_path().string();
  const bool side_files_writable = access((path + "-wal").c_str(), W_OK) == 0 && access((path + "-shm").c_str(), W_OK) == 0;
  if (access(folder.c_str(), W_OK) != 0 && !side_files_writable)
    return fmt::format("not writable by this user (its folder {}, where SQLite keeps the study's -wal and -shm files: "
                       "{})",
                       folder, std::strerror(errno));
  return "";
}

/// `path` as an SQLite URI filename (RFC 3986 percent-encoding of everything but unreserved characters and '/').
std::string sqlite_uri(const std::string& path, const char* query) {
  std::string out = "file:";
  for (const unsigned char c : path) {
    if (ascii_alnum(static_cast<char>(c)) || c == '/' || c == '-' || c == '_' || c == '.' || c == '~')
      out += static_cast<char>(c);
    else
      out += fmt::format("%{:02X}", c);
  }
  return out + "?" + query;
}

const char* kSchema = R"SQL(
CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE trials (
  id INTEGER PRIMARY KEY,
  state TEXT NOT NULL CHECK (state IN ('pending', 'complete', 'failed', 'abandoned')),
  phase TEXT NOT NULL DEFAULT '',
  x TEXT NOT NULL,
  theta TEXT NOT NULL,
  cost REAL,
  components TEXT NOT NULL DEFAULT '{}',
  noiseless_cost REAL,
  error TEXT NOT NULL DEFAULT '',
  worker TEXT NOT NULL DEFAULT '',
  created_at REAL NOT NULL,
  finished_at REAL NOT NULL DEFAULT 0,
  finish_seq INTEGER NOT NULL DEFAULT -1,
  finished_before INTEGER NOT NULL DEFAULT 0,
  pending_before INTEGER NOT NULL DEFAULT 0,
  batch_size INTEGER NOT NULL DEFAULT 1,
  batch_index INTEGER NOT NULL DEFAULT 0,
  fit_seconds REAL NOT NULL DEFAULT 0,
  acquisition_seconds REAL NOT NULL DEFAULT 0,
  evaluation_seconds REAL NOT NULL DEFAULT 0
);
CREATE INDEX trials_state ON trials (state);
CREATE INDEX trials_finish_seq ON trials (finish_seq);
CREATE TABLE snapshots (
  id INTEGER PRIMARY KEY,
  after_trials INTEGER NOT NULL,
  iteration INTEGER NOT NULL,
  objective REAL,
  note TEXT NOT NULL DEFAULT '',
  region_state TEXT NOT NULL DEFAULT '',
  hyperparameters TEXT NOT NULL
);
)SQL";

// Schema version 2: the algorithm's saved state (docs/studies.md, "Snapshots"). Created by new stores and
// added to version-1 stores when they are opened.
const char* kAlgorithmStates = R"SQL(
CREATE TABLE IF NOT EXISTS algorithm_states (
  id INTEGER PRIMARY KEY,
  finished INTEGER NOT NULL,
  outstanding INTEGER NOT NULL DEFAULT -1,
  state TEXT NOT NULL,
  created_at REAL NOT NULL
);
CREATE TABLE IF NOT EXISTS workers (
  id TEXT PRIMARY KEY,
  host TEXT NOT NULL,
  pid INTEGER NOT NULL,
  started_at REAL NOT NULL,
  heartbeat_at REAL NOT NULL,
  state TEXT NOT NULL
);
)SQL";

/// The study files this process holds a write transaction on, and in which thread: a second Study object of the
/// same file called from inside the first's transaction() in the same thread waited 10 minutes for a lock its own
/// thread held, "held by another process" (red team, session 30). Refused at once instead; another thread's is named.
class OpenTransactions {
 public:
  using Key = std::pair<std::uint64_t, std::uint64_t>;  // device, inode; {0, 0}: not known
  static Key key_of(const std::string& path) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) return {0, 0};
    return {static_cast<std::uint64_t>(st.st_dev), static_cast<std::uint64_t>(st.st_ino)};
  }
  static void check_this_thread(const Key& file, const std::string& path) {
    if (file == Key{0, 0}) return;
    std::lock_guard<std::mutex> lock(mutex());
    const auto it = held().find(file);
    if (it != held().end() && it->second == std::this_thread::get_id())
      throw InputError(fmt::format("{}: another varbo::Study object of this study holds a transaction in this thread "
                                   "(a call made inside the other object's transaction()): make the call on that "
                                   "object; nothing written",
                                   path));
  }
  static bool held_in_this_process(const Key& file) {
    if (file == Key{0, 0}) return false;
    std::lock_guard<std::mutex> lock(mutex());
    return held().count(file) > 0;
  }
  static void enter(const Key& file) {
    if (file == Key{0, 0}) return;
    std::lock_guard<std::mutex> lock(mutex());
    held()[file] = std::this_thread::get_id();
  }
  static void leave(const Key& file) {
    if (file == Key{0, 0}) return;
    std::lock_guard<std::mutex> lock(mutex());
    held().erase(file);
  }

 private:
  static std::mutex& mutex() {
    static std::mutex m;
    return m;
  }
  static std::map<Key, std::thread::id>& held() {
    static auto* m = new std::map<Key, std::thread::id>();  // never destroyed: used by destructors at exit
    return *m;
  }
};

class SqliteStore;

/// A prepared statement; errors name the store file.
class Statement {
 public:
  Statement(sqlite3* db, const std::string& sql, const std::string& file) : db_(db), file_(file) {
    if (sqlite3_prepare_v2(db, sql.c_str(), -1, &stmt_, nullptr) != SQLITE_OK) fail("prepare");
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  Statement& bind(int i, double v) {
    // SQLite stores NaN as NULL; read back as NaN.
    check(std::isnan(v) ? sqlite3_bind_null(stmt_, i) : sqlite3_bind_double(stmt_, i, v));
    return *this;
  }
  Statement& bind(int i, std::int64_t v) {
    check(sqlite3_bind_int64(stmt_, i, v));
    return *this;
  }
  Statement& bind(int i, const std::string& v) {
    check(sqlite3_bind_text(stmt_, i, v.c_str(), static_cast<int>(v.size()), SQLITE_TRANSIENT));
    return *this;
  }
  /// True while a row is available.
  bool step() {
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    fail("step");
  }
  double real(int c) const {
    const int type = sqlite3_column_type(stmt_, c);
    if (type == SQLITE_NULL) return std::nan("");
    // A number column holding text ("1,5" typed by hand in the sqlite3 shell) read as its numeric prefix or 0:
    // a cost of 0 became the study's best trial.
    if (type != SQLITE_INTEGER && type != SQLITE_FLOAT) {
      const auto* p = sqlite3_column_text(stmt_, c);
      throw InputError(fmt::format("{}: corrupt study: column '{}' holds '{}' where a number is stored{}", file_,
                                   sqlite3_column_name(stmt_, c), p ? safe_text(reinterpret_cast<const char*>(p), 40) : "",
                                   row_hint()));
    }
    return sqlite3_column_double(stmt_, c);
  }
  std::int64_t integer(int c) const { return sqlite3_column_int64(stmt_, c); }
  /// " (id N)" when the row's first column is its id (a trial's): where a corrupt cell is.
  std::string row_hint() const {
    const char* first = sqlite3_column_name(stmt_, 0);
    return first && std::string(first) == "id" ? fmt::format(" (id {})", sqlite3_column_int64(stmt_, 0)) : "";
  }
  std::string text(int c) const {
    const auto* p = sqlite3_column_text(stmt_, c);
    return p ? std::string(reinterpret_cast<const char*>(p)) : std::string();
  }

 private:
  void check(int rc) {
    if (rc != SQLITE_OK) fail("bind");
  }
  [[noreturn]] void fail(const char* what) const {
    throw InputError(fmt::format("{}: SQLite {} failed: {}", file_, what, sqlite3_errmsg(db_)));
  }
  sqlite3* db_;
  sqlite3_stmt* stmt_ = nullptr;
  const std::string& file_;
};

class SqliteStore final : public StudyStore {
 public:
  SqliteStore(const std::string& path, bool create) : path_(path) {
    namespace fs = std::filesystem;
    if (create && fs::exists(path))
      throw InputError(fmt::format("{}: a file with this name exists already; choose another study file or "
                                   "continue it with `varbo suggest`/`varbo run --resume`",
                                   path));
    if (!create && !fs::exists(path)) throw InputError(fmt::format("{}: no such study file", path));
    std::error_code ec;
    if (fs::is_directory(path, ec)) {  // a run folder given for its study: name the file inside it
      const std::string inside = (fs::path(path) / "study.db").string();
      throw InputError(fmt::format("{}: a folder, not a study file{}", path,
                                   fs::exists(inside, ec) ? " (this run folder's study is " + inside + ")" : ""));
    }
    // SQLite names a database's journal (-wal, -shm) and varbo its run lock after the name used: through a hard
    // link a second `varbo run` took its own lock and journal, both drove the study and 4 of 8 trials were lost,
    // with `study verify` ok (red team, session 34). One file, one name.
    struct stat links {};
    if (!create && ::stat(path.c_str(), &links) == 0 && S_ISREG(links.st_mode) && links.st_nlink > 1)
      throw InputError(fmt::format("{}: the study file has {} names (hard links); SQLite keeps its journal and varbo "
                                   "its run lock under the name used, so two names would let two writers in. Open it "
                                   "by one name: remove the other links, or `cp` the file for an independent copy",
                                   path, static_cast<unsigned long>(links.st_nlink)));
    // Before SQLite opens them: a FIFO as the study's -journal hung every command (red team, session 37).
    require_plain_side_files(path);
    const int flags = SQLITE_OPEN_READWRITE | (create ? SQLITE_OPEN_CREATE : 0) | SQLITE_OPEN_FULLMUTEX;
    if (sqlite3_open_v2(path.c_str(), &db_, flags, nullptr) != SQLITE_OK) {
      const std::string msg = db_ ? sqlite3_errmsg(db_) : "out of memory";
      sqlite3_close(db_);
      db_ = nullptr;
      // SQLite's own limit (SQLITE_MAX_PATHNAME 512, with room for "-journal"/"-wal"): "unable to open database
      // file" alone gave no reason in a deep folder (red team, session 28).
      std::error_code ec;
      const std::size_t length = std::filesystem::absolute(path, ec).string().size();
      // "unable to open database file" alone, for a study another user made with umask 077 (red team, session 29).
      if (!create && ::access(path.c_str(), R_OK) != 0) {
        struct stat st {};
        const int err = errno;
        if (::stat(path.c_str(), &st) == 0)
          throw InputError(fmt::format("{}: cannot open the study file: {} (owned by uid {}, mode {:04o}); its owner "
                                       "can share it with `chmod g+rw`",
                                       path, std::strerror(err), st.st_uid, st.st_mode & 07777));
      }
      throw InputError(fmt::format("{}: cannot open the study file: {}{}", path, msg,
                                   length > 480 ? fmt::format(" (its absolute path is {} bytes; SQLite opens paths of "
                                                              "at most ~500: use a shorter folder)",
                                                              length)
                                                : ""));
    }
    if (!create) {
      std::string why = clear_foreign_side_files(path);
      if (why.empty()) why = read_only_reason(path);
      if (!why.empty()) reopen_read_only(why);
    }
    sqlite3_busy_handler(db_, &SqliteStore::busy_wait, this);
    try {
      if (create) {
        exec("PRAGMA journal_mode=WAL");  // persistent: every later connection uses WAL too
        transaction([&] {
          exec(kSchema);
          exec(kAlgorithmStates);
          set_meta("format", kFormat);
          set_meta("schema_version", std::to_string(kSchemaVersion));
        });
      } else {
        check_format();
        if (!read_only_) upgrade();
      }
      if (!read_only_) exec("PRAGMA synchronous=NORMAL");  // WAL + NORMAL: a commit survives a process crash (not a power loss)
      exec("PRAGMA foreign_keys=ON");
    } catch (...) {
      sqlite3_close(db_);
      db_ = nullptr;
      if (create) {
        std::error_code ec;
        fs::remove(path, ec);
      }
      throw;
    }
  }
  ~SqliteStore() override { sqlite3_close(db_); }

  /// Copies the WAL into the file and empties it, or throws: a new study is published by linking its file alone,
  /// and the close's own checkpoint fails silently (a full disk left a study file without its tables, linked into
  /// place, while its data went with the removed -wal; red team, session 25).
  void checkpoint_into_file() {
    long long busy = -1;  // the pragma's first column: 1 when the checkpoint could not complete
    char* err = nullptr;
    const int rc = sqlite3_exec(
        db_, "PRAGMA wal_checkpoint(TRUNCATE)",
        [](void* out, int n, char** values, char**) {
          if (n >= 1 && values[0]) *static_cast<long long*>(out) = std::atoll(values[0]);
          return 0;
        },
        &busy, &err);
    if (rc != SQLITE_OK || busy != 0) {
      const std::string msg = err ? err : (rc != SQLITE_OK ? sqlite3_errmsg(db_) : "the checkpoint was incomplete");
      sqlite3_free(err);
      throw InputError(fmt::format("{}: cannot write the new study's file: {}", path_, msg));
    }
    sqlite3_free(err);
  }

  const std::string& location() const override { return path_; }

  void transaction(const std::function<void()>& body) override {
    if (depth_ > 0) {  // join the outer transaction
      ++depth_;
      try {
        body();
      } catch (...) {
        --depth_;
        throw;
      }
      --depth_;
      return;
    }
    if (read_only_)
      throw InputError(fmt::format("{}: the study is {}: it can be read (varbo status, export, plot, dashboard) but "
                                   "not changed; copy its folder to a writable place to continue it",
                                   path_, read_only_why_));
    const OpenTransactions::Key file = OpenTransactions::key_of(path_);
    OpenTransactions::check_this_thread(file, path_);
    begin_immediate(file);
    OpenTransactions::enter(file);
    depth_ = 1;
    try {
      body();
      commit();
    } catch (...) {
      depth_ = 0;
      sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
      OpenTransactions::leave(file);
      throw;
    }
    depth_ = 0;
    OpenTransactions::leave(file);
  }

  std::optional<std::string> meta(const std::string& key) const override {
    Statement s(db_, "SELECT value FROM meta WHERE key = ?", path_);
    s.bind(1, key);
    if (!s.step()) return std::nullopt;
    return s.text(0);
  }
  void set_meta(const std::string& key, const std::string& value) override {
    Statement s(db_, "INSERT INTO meta (key, value) VALUES (?, ?) ON CONFLICT(key) DO UPDATE SET value = excluded.value",
                path_);
    s.bind(1, key).bind(2, value).step();
  }

  std::vector<TrialRecord> trials() const override { return select_trials("ORDER BY id", std::nullopt); }
  std::optional<TrialRecord> trial(std::int64_t id) const override {
    auto v = select_trials("WHERE id = ?", id);
    if (v.empty()) return std::nullopt;
    return v.front();
  }

  std::vector<TrialRecord> finished_since(std::int64_t seq) const override {
    // `+state`: the unary plus keeps SQLite from the state index (every finished trial, then a sort) and on the
    // finish_seq one (only the trials since `seq`): 0.36 → 0.02 ms at N = 2000, run several times per trial.
    return select_trials("WHERE finish_seq >= ? AND +state IN ('complete', 'failed') ORDER BY finish_seq", seq);
  }
  std::vector<TrialRecord> pending_trials() const override {
    return select_trials("WHERE state = 'pending' ORDER BY id", std::nullopt);
  }

  std::int64_t add_trial(const TrialRecord& t) override {
    std::int64_t id = 0;
    {
      Statement s(db_, "SELECT COALESCE(MAX(id) + 1, 0) FROM trials", path_);
      s.step();
      id = s.integer(0);
    }
    TrialRecord r = t;
    r.id = id;
    Statement s(db_, std::string("INSERT INTO trials (") + kColumns + ") VALUES (" + kPlaceholders + ")", path_);
    bind_trial(s, r);
    s.step();
    return id;
  }

  void update_trial(const TrialRecord& t) override {
    Statement s(db_, std::string("UPDATE trials SET (") + kColumns + ") = (" + kPlaceholders + ") WHERE id = ?21",
                path_);
    bind_trial(s, t);
    s.bind(21, t.id);
    s.step();
    if (sqlite3_changes(db_) != 1) throw InputError(fmt::format("{}: no trial with id {}", path_, t.id));
  }

  std::int64_t next_finish_seq() const override {
    Statement s(db_, "SELECT COALESCE(MAX(finish_seq) + 1, 0) FROM trials", path_);
    s.step();
    return std::max<std::int64_t>(0, s.integer(0));
  }

  void add_snapshot(const StoredSnapshot& snap) override {
    nlohmann::json h = nlohmann::json::array();
    for (const auto& p : snap.snapshot.hyperparameters) h.push_back({p.name, p.value});
    Statement s(db_,
                "INSERT INTO snapshots (after_trials, iteration, objective, note, hyperparameters, region_state) "
                "VALUES (?, ?, ?, ?, ?, ?)",
                path_);
    s.bind(1, snap.after_trials)
        .bind(2, static_cast<std::int64_t>(snap.snapshot.iteration))
        .bind(3, snap.snapshot.objective)
        .bind(4, snap.snapshot.note)
        .bind(5, h.dump())
        .bind(6, snap.snapshot.region_state);
    s.step();
  }

  void add_algorithm_state(const AlgorithmSnapshot& snap) override {
    Statement s(db_, "INSERT INTO algorithm_states (finished, outstanding, state, created_at) VALUES (?, ?, ?, ?)",
                path_);
    s.bind(1, snap.finished).bind(2, snap.outstanding).bind(3, snap.state).bind(4, snap.created_at);
    s.step();
    Statement prune(db_, "DELETE FROM algorithm_states WHERE finished < ?", path_);
    prune.bind(1, snap.finished - 2);
    prune.step();
  }

  std::vector<AlgorithmSnapshot> algorithm_states() const override {
    std::vector<AlgorithmSnapshot> out;
    Statement s(db_, "SELECT finished, outstanding, state, created_at FROM algorithm_states ORDER BY id DESC", path_);
    while (s.step()) {
      AlgorithmSnapshot a;
      a.finished = s.integer(0);
      a.outstanding = s.integer(1);
      a.state = s.text(2);
      a.created_at = s.real(3);
      out.push_back(std::move(a));
    }
    return out;
  }

  void put_worker(const WorkerRecord& w) override {
    Statement s(db_,
                "INSERT INTO workers (id, host, pid, started_at, heartbeat_at, state) VALUES (?, ?, ?, ?, ?, ?) "
                "ON CONFLICT(id) DO UPDATE SET heartbeat_at = excluded.heartbeat_at, state = excluded.state",
                path_);
    s.bind(1, w.id).bind(2, w.host).bind(3, static_cast<std::int64_t>(w.pid)).bind(4, w.started_at);
    s.bind(5, w.heartbeat_at).bind(6, w.state);
    s.step();
  }

  std::vector<WorkerRecord> workers() const override {
    std::vector<WorkerRecord> out;
    Statement s(db_, "SELECT id, host, pid, started_at, heartbeat_at, state FROM workers ORDER BY started_at", path_);
    while (s.step()) {
      WorkerRecord w;
      w.id = s.text(0);
      w.host = s.text(1);
      w.pid = static_cast<long>(s.integer(2));
      w.started_at = s.real(3);
      w.heartbeat_at = s.real(4);
      w.state = s.text(5);
      out.push_back(std::move(w));
    }
    return out;
  }

  std::vector<StoredSnapshot> snapshots() const override {
    std::vector<StoredSnapshot> out;
    Statement s(db_, "SELECT after_trials, iteration, objective, note, hyperparameters, region_state FROM snapshots ORDER BY id",
                path_);
    while (s.step()) {
      StoredSnapshot r;
      r.after_trials = s.integer(0);
      r.snapshot.iteration = static_cast<Index>(s.integer(1));
      r.snapshot.objective = s.real(2);
      r.snapshot.note = s.text(3);
      r.snapshot.region_state = s.text(5);
      nlohmann::json h = nlohmann::json::parse(s.text(4), nullptr, false);
      if (h.is_array())
        for (const auto& p : h)
          if (p.is_array() && p.size() == 2 && p[0].is_string() && p[1].is_number())
            r.snapshot.hyperparameters.push_back({p[0].get<std::string>(), p[1].get<double>()});
      out.push_back(std::move(r));
    }
    return out;
  }

 private:
  static constexpr const char* kColumns =
      "id, state, phase, x, theta, cost, components, noiseless_cost, error, worker, created_at, finished_at, "
      "finish_seq, finished_before, pending_before, batch_size, batch_index, fit_seconds, acquisition_seconds, "
      "evaluation_seconds";
  static constexpr const char* kPlaceholders = "?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17, ?18, ?19, ?20";

  void bind_trial(Statement& s, const TrialRecord& t) const {
    s.bind(1, t.id)
        .bind(2, state_name(t.state))
        .bind(3, t.phase)
        .bind(4, vec_text(t.x))
        .bind(5, vec_text(t.theta))
        .bind(6, t.cost)
        .bind(7, components_text(t.components))
        .bind(8, t.noiseless_cost)
        .bind(9, t.error)
        .bind(10, t.worker)
        .bind(11, t.created_at)
        .bind(12, t.finished_at)
        .bind(13, t.finish_seq)
        .bind(14, t.finished_before)
        .bind(15, t.pending_before)
        .bind(16, t.batch_size)
        .bind(17, t.batch_index)
        .bind(18, t.fit_seconds)
        .bind(19, t.acquisition_seconds)
        .bind(20, t.evaluation_seconds);
  }

  /// A trial's vector; the message naming the trial is formatted only for a corrupt one (a study's open reads
  /// every finished trial).
  Vec trial_vec(const std::string& text, std::int64_t id) const {
    if (Vec v; read_number_array(text, v)) return v;
    return text_vec(text, fmt::format("{}: trial {}", path_, id));
  }

  std::vector<TrialRecord> select_trials(const std::string& clause, std::optional<std::int64_t> id) const {
    std::vector<TrialRecord> out;
    Statement s(db_, std::string("SELECT ") + kColumns + " FROM trials " + clause, path_);
    if (id) s.bind(1, *id);
    while (s.step()) {
      TrialRecord t;
      t.id = s.integer(0);
      t.state = state_from_name(s.text(1));
      t.phase = s.text(2);
      t.x = trial_vec(s.text(3), t.id);
      t.theta = trial_vec(s.text(4), t.id);
      t.cost = s.real(5);
      t.components = text_components(s.text(6));
      t.noiseless_cost = s.real(7);
      t.error = s.text(8);
      t.worker = s.text(9);
      t.created_at = s.real(10);
      t.finished_at = s.real(11);
      t.finish_seq = s.integer(12);
      t.finished_before = s.integer(13);
      t.pending_before = s.integer(14);
      t.batch_size = s.integer(15);
      t.batch_index = s.integer(16);
      t.fit_seconds = s.real(17);
      t.acquisition_seconds = s.real(18);
      t.evaluation_seconds = s.real(19);
      out.push_back(std::move(t));
    }
    return out;
  }

  void exec(const char* sql) {
    char* err = nullptr;
    if (sqlite3_exec(db_, sql, nullptr, nullptr, &err) != SQLITE_OK) {
      const std::string msg = err ? err : sqlite3_errmsg(db_);
      sqlite3_free(err);
      throw InputError(fmt::format("{}: SQLite: {}", path_, msg));
    }
  }

  // SQLite's busy timeout (kBusyTimeoutMs per attempt), but one that a stop signal ends: a SIGTERM to `varbo run`
  // waiting for the write lock after a trial (an `sqlite3` shell or a backup holding it) was ignored for as long
  // as the lock was held, and a second signal then killed it with the trial's result neither stored nor said (red
  // team, session 34). Once a signal has arrived the wait goes on for at most kInterruptedWaitMs (a result is still
  // stored if the lock comes free at once); then the caller throws Interrupted and the run says how to record it.
  static int busy_wait(void* self, int count) {
    auto* store = static_cast<SqliteStore*>(self);
    const auto now = std::chrono::steady_clock::now();
    if (count == 0) store->busy_since_ = now;
    const auto waited = std::chrono::duration_cast<std::chrono::milliseconds>(now - store->busy_since_).count();
    if (waited >= kBusyTimeoutMs) return 0;
    if (interrupt_requested() != 0) {
      if (store->interrupted_at_ == std::chrono::steady_clock::time_point{}) store->interrupted_at_ = now;
      const auto since = std::chrono::duration_cast<std::chrono::milliseconds>(now - store->interrupted_at_).count();
      if (since >= kInterruptedWaitMs) return 0;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(std::min(1 + count, 25)));
    return 1;
  }
  void stop_if_interrupted() const {
    if (const int sig = interrupt_requested(); sig != 0) throw Interrupted(sig);
  }

  void begin_immediate(const OpenTransactions::Key& file = {}) {
    for (int attempt = 1;; ++attempt) {
      const int rc = sqlite3_exec(db_, "BEGIN IMMEDIATE", nullptr, nullptr, nullptr);
      if (rc == SQLITE_OK) return;
      if (rc == SQLITE_BUSY || rc == SQLITE_LOCKED) stop_if_interrupted();
      if ((rc != SQLITE_BUSY && rc != SQLITE_LOCKED) || attempt >= kBeginAttempts)
        throw InputError(fmt::format("{}: cannot start a transaction after {} attempts: {}", path_, attempt,
                                     sqlite3_errmsg(db_)));
      say_still_waiting(attempt, OpenTransactions::held_in_this_process(file));
      std::this_thread::sleep_for(std::chrono::milliseconds(10 * attempt));
    }
  }

  // Each failed attempt has waited kBusyTimeoutMs: a process holding a write transaction (an `sqlite3` shell left
  // in BEGIN, a backup, a stalled writer) kept every command silent for up to 10 min (red team, session 28).
  void say_still_waiting(int attempt, bool this_process = false) const {
    if (attempt != 1 && attempt % 6 != 0) return;
    const std::string text = fmt::format(
        "{}: waiting for the study's write lock, held by {}; waited {} s so far, giving up after ~{} min", path_,
        this_process ? "another Study object of this process (in another thread)"
                     : "another process (a varbo command fitting its model, an open `sqlite3` shell, a backup)",
        attempt * kBusyTimeoutMs / 1000, kBeginAttempts * kBusyTimeoutMs / 60000);
    if (attempt == 1) log_info("{}", text);
    else log_warn("{}", text);
  }

  void commit() {
    for (int attempt = 1;; ++attempt) {
      const int rc = sqlite3_exec(db_, "COMMIT", nullptr, nullptr, nullptr);
      if (rc == SQLITE_OK) return;
      if (rc == SQLITE_BUSY) stop_if_interrupted();
      if (rc != SQLITE_BUSY || attempt >= kBeginAttempts)
        throw InputError(fmt::format("{}: commit failed: {}", path_, sqlite3_errmsg(db_)));
      say_still_waiting(attempt);
      std::this_thread::sleep_for(std::chrono::milliseconds(10 * attempt));
    }
  }

  void check_format() {
    // A file that is not SQLite fails at the first read (SQLITE_NOTADB); an SQLite file without our meta
    // table or format marker is someone else's database.
    sqlite3_stmt* probe = nullptr;
    const int rc = sqlite3_prepare_v2(db_, "SELECT value FROM meta WHERE key = 'format'", -1, &probe, nullptr);
    std::string format;
    int step_rc = SQLITE_OK;
    if (rc == SQLITE_OK) {
      step_rc = sqlite3_step(probe);
      if (step_rc == SQLITE_ROW) {
        const auto* p = sqlite3_column_text(probe, 0);
        format = p ? reinterpret_cast<const char*>(p) : "";
      }
    }
    const int err = rc != SQLITE_OK ? rc : step_rc;
    const std::string msg = sqlite3_errmsg(db_);
    sqlite3_finalize(probe);
    if (err == SQLITE_NOTADB)
      throw InputError(fmt::format("{}: not a varbo study store (the file is not an SQLite database)", path_));
    if (rc != SQLITE_OK && msg.find("no such table") != std::string::npos)
      throw InputError(fmt::format("{}: not a varbo study store (an SQLite database without varbo's meta table)",
                                   path_));
    if (rc != SQLITE_OK || (step_rc != SQLITE_ROW && step_rc != SQLITE_DONE))
      throw InputError(fmt::format("{}: cannot read the study store: {}", path_, msg));
    if (format != kFormat)
      throw InputError(fmt::format("{}: not a varbo study store (meta 'format' is '{}', expected '{}')", path_, format,
                                   kFormat));
    const auto v = meta("schema_version");
    const int version = store_codec::schema_version_of(v);
    if (version < 1)
      throw InputError(fmt::format("{}: corrupt varbo study store (schema_version '{}')", path_, v.value_or("")));
    if (version > kSchemaVersion)
      throw InputError(fmt::format("{}: written by a newer varbo (store schema version {}; this varbo reads up to "
                                   "version {}); upgrade varbo to open it",
                                   path_, version, kSchemaVersion));
  }

  /// A version-1 store gains the algorithm_states table (older varbo versions then refuse it as newer).
  void upgrade() {
    const auto v = meta("schema_version");
    if (store_codec::schema_version_of(v) >= kSchemaVersion && has_table("algorithm_states") && has_table("workers")) return;
    transaction([&] {
      exec(kAlgorithmStates);
      set_meta("schema_version", std::to_string(kSchemaVersion));
    });
  }

  /// A study on a read-only mount (a finished experiment archived, a snapshot, a CD): SQLite's WAL mode needs its
  /// `-shm` index, which it cannot create there, so a plain open fails at the first read ("unable to open database
  /// file"). Without a `-wal` holding changes the file alone is the whole study and is opened `immutable` (no
  /// locks, no index: nothing can change it on this mount); with a `-shm` next to it SQLite reads the `-wal` through a
  /// private copy of the index; a `-wal` without its `-shm` cannot be read, which is said rather than showing an
  /// older state of the study.
  void reopen_read_only(const std::string& why) {
    read_only_why_ = why;
    namespace fs = std::filesystem;
    std::error_code ec;
    const auto wal_size = fs::file_size(path_ + "-wal", ec);
    const bool wal_has_changes = !ec && wal_size > 0;
    const bool has_shm = fs::exists(path_ + "-shm", ec);
    sqlite3_close(db_);
    db_ = nullptr;
    if (wal_has_changes && !has_shm)
      throw InputError(fmt::format("{}: the study is {} and its newest changes are in {}-wal, which SQLite cannot "
                                   "read without its {}-shm; copy the folder to a writable place and open the copy",
                                   path_, why, path_, path_));
    // Without a -shm no process has the study open: read the file as it is (immutable: a WAL-mode study opened
    // otherwise makes its -wal). readonly_shm=1: a reader never creates the -shm either. Made by a reader, they
    // belonged to that reader and blocked the study's owner (red team, session 29); a -wal made in the instant an
    // owner closes is cleared by the owner's next write (clear_foreign_side_files).
    const bool frozen = !has_shm;
    const std::string uri = sqlite_uri(path_, frozen ? "immutable=1" : "mode=ro&readonly_shm=1");
    if (sqlite3_open_v2(uri.c_str(), &db_, SQLITE_OPEN_READONLY | SQLITE_OPEN_URI | SQLITE_OPEN_FULLMUTEX, nullptr) !=
        SQLITE_OK) {
      const std::string msg = db_ ? sqlite3_errmsg(db_) : "out of memory";
      sqlite3_close(db_);
      db_ = nullptr;
      throw InputError(fmt::format("{}: cannot open the study file ({}): {}", path_, why, msg));
    }
    read_only_ = true;
    log_debug("{}: {}; opened read-only{}", path_, why, frozen ? " (immutable)" : "");
  }

  bool has_table(const std::string& name) const {
    Statement s(db_, "SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = ?", path_);
    s.bind(1, name);
    return s.step();
  }

  std::string path_;
  sqlite3* db_ = nullptr;
  std::chrono::steady_clock::time_point busy_since_{}, interrupted_at_{};  // busy_wait's clocks
  int depth_ = 0;
  bool read_only_ = false;  ///< on a read-only file system or not writable by this user: reads only (reopen_read_only)
  std::string read_only_why_;
};

}  // namespace

namespace {
/// The umask, read without changing it: umask(0) and back left a window in which a file another thread of the
/// process created got mode 0666 (red team, session 30: a Python thread writing files beside Study.create).
mode_t process_umask() {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);)
    if (line.rfind("Umask:", 0) == 0) return static_cast<mode_t>(std::strtoul(line.c_str() + 6, nullptr, 8));
  const mode_t mask = ::umask(0);  // no /proc: read, and put back at once
  ::umask(mask);
  return mask;
}
}  // namespace

std::unique_ptr<StudyStore> create_sqlite_store(const std::string& path,
                                                const std::vector<std::pair<std::string, std::string>>& meta) {
  // Built under a temporary name and linked into place complete: a crash never leaves a half-made store,
  // and two processes creating the same study cannot both succeed (link() refuses an existing name).
  namespace fs = std::filesystem;
  if (fs::exists(path))
    throw InputError(fmt::format("{}: a file with this name exists already; choose another study file or continue "
                                 "it with `varbo suggest`/`varbo run --resume`",
                                 path));
  // SQLite replays a hot journal or WAL that carries the new file's name into it: a -wal left by an earlier
  // study of this name (moved away while open, or a crash) made its tables and trials appear in the new one.
  for (const char* suffix : {"-wal", "-journal"}) {
    std::error_code ec;
    if (fs::exists(path + suffix, ec))
      throw InputError(fmt::format("{0}{1}: a leftover SQLite {2} of an earlier file named {0} exists; SQLite would "
                                   "replay it into the new study. Move it away (with its study file, if you still "
                                   "have that) or choose another name",
                                   path, suffix, suffix + 1));
  }
  {
    // Said of the path given, before the temporary file's name ("x.db.creating-16419: cannot open the study file:
    // unable to open database file") stood for a folder that does not exist (red team, session 23).
    std::error_code ec;
    const fs::path folder = fs::absolute(path, ec).parent_path();
    if (!fs::is_directory(folder, ec))
      throw InputError(fmt::format("{}: cannot create the study file: the folder {} does not exist", path,
                                   folder.string()));
  }
  // Per thread: threads of one process creating the same study removed each other's file (cleanup()), and every
  // one of them failed (red team, session 30).
  const std::string tmp = fmt::format("{}.creating-{}-{}", path, static_cast<long>(getpid()), static_cast<long>(gettid()));
  auto cleanup = [&] {
    std::error_code ec;
    for (const char* suffix : {"", "-wal", "-shm", "-journal"}) fs::remove(tmp + suffix, ec);
  };
  cleanup();
  {
    // Said with the reason: SQLite's "unable to open database file" was all a read-only mount got (audit,
    // session 45). access() answers EROFS for a read-only file system, EACCES for a folder without write permission.
    std::error_code ec;
    const fs::path folder = fs::absolute(fs::path(path), ec).parent_path();
    if (!ec && ::access(folder.c_str(), W_OK) != 0)
      throw InputError(fmt::format("{}: cannot create the study file in {}: {}; no study file was created", path,
                                   folder.string(), std::strerror(errno)));
  }
  try {
    SqliteStore store(tmp, true);
    store.transaction([&] {
      for (const auto& [k, v] : meta) store.set_meta(k, v);
    });
    store.checkpoint_into_file();
    // SQLite makes its files 0644 whatever the umask: with `umask 002` in a lab's group folder, everything else
    // varbo wrote was group-writable but the study was not, and a colleague's worker was refused (red team,
    // session 29). The file gets 0666 less the umask, as any new file; its -wal and -shm take its mode.
    ::chmod(tmp.c_str(), 0666 & ~process_umask());
  } catch (const InputError& e) {
    cleanup();
    std::string msg = e.what();  // said of the study's name, not of the temporary file's
    for (std::size_t at = msg.find(tmp); at != std::string::npos; at = msg.find(tmp, at + path.size()))
      msg.replace(at, tmp.size(), path);
    throw InputError(msg + "; no study file was created");
  } catch (...) {
    cleanup();
    throw;
  }
  const int rc = link(tmp.c_str(), path.c_str());
  const int err = errno;
  cleanup();
  if (rc != 0)
    throw InputError(fmt::format("{}: cannot create the study file: {}", path,
                                 err == EEXIST ? "a file with this name exists already" : std::strerror(err)));
  try {
    return std::make_unique<SqliteStore>(path, false);
  } catch (const InputError& e) {
    // Made but unusable (`umask 777` gave it mode 000): it was left behind, and a retry said "exists already"
    // (red team, session 28). It is ours, just linked: removed, with the empty -wal the failed open made (a retry
    // was refused as "a leftover SQLite wal of an earlier file"; session 30). Creation refuses an existing -wal, so
    // one here is this attempt's.
    std::error_code ec;
    fs::remove(path, ec);
    const fs::path wal = path + "-wal";
    if (fs::is_regular_file(fs::symlink_status(wal, ec)) && fs::file_size(wal, ec) == 0) fs::remove(wal, ec);
    const mode_t mask = process_umask();
    throw InputError(fmt::format("{}; no study file was created{}", e.what(),
                                 (mask & 0600) != 0 ? " (the process's umask leaves the file's owner no read/write "
                                                      "permission: check `umask`)"
                                                    : ""));
  }
}

std::unique_ptr<StudyStore> open_sqlite_store(const std::string& path) {
  return std::make_unique<SqliteStore>(path, false);
}

}  // namespace varbo
