// The PostgreSQL study store (libpqxx): one database holds any number of studies, each a row of varbo_studies
// and its rows in the shared tables, keyed by the study's name. Several machines share a study through the
// server. A transaction locks the study's row (SELECT ... FOR NO KEY UPDATE), so suggestions and results of one
// study serialize exactly as SQLite's BEGIN IMMEDIATE does, while other studies in the database run freely;
// the server's serialization failures and deadlocks are retried with backoff. Every libpqxx error becomes an
// InputError naming the study and the cause. Built as libvarbo_study_postgres.so, loaded on the first
// postgresql:// address (src/store/postgres_backend.hpp).
#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <map>
#include <pqxx/pqxx>
#include <random>
#include <thread>
#include <vector>

#include "connection_pool.hpp"
#include "postgres_backend.hpp"
#include "store_codec.hpp"
#include "store_url.hpp"
#include "varbo/errors.hpp"
#include "varbo/log.hpp"
#include "varbo/store.hpp"
#include "varbo/numbers.hpp"

namespace varbo {

namespace {

using namespace store_codec;

constexpr const char* kFormat = "varbo-study";
constexpr int kRetryAttempts = 12;       // serialization failures / deadlocks: backoff 20 ms × 2^k, capped at 2 s
constexpr long kCreateLockKey = 0x76617262;  // advisory lock serializing the creation of the tables ("varb")

// Every study's rows carry its name; deleting the study's row deletes them all.
const char* kSchema = R"SQL(
CREATE TABLE IF NOT EXISTS varbo_studies (
  name TEXT PRIMARY KEY,
  created_at DOUBLE PRECISION NOT NULL
);
CREATE TABLE IF NOT EXISTS varbo_meta (
  study TEXT NOT NULL REFERENCES varbo_studies (name) ON DELETE CASCADE,
  key TEXT NOT NULL,
  value TEXT NOT NULL,
  PRIMARY KEY (study, key)
);
CREATE TABLE IF NOT EXISTS varbo_trials (
  study TEXT NOT NULL REFERENCES varbo_studies (name) ON DELETE CASCADE,
  id BIGINT NOT NULL,
  state TEXT NOT NULL CHECK (state IN ('pending', 'complete', 'failed', 'abandoned')),
  phase TEXT NOT NULL DEFAULT '',
  x TEXT NOT NULL,
  theta TEXT NOT NULL,
  cost DOUBLE PRECISION,
  components TEXT NOT NULL DEFAULT '[]',
  noiseless_cost DOUBLE PRECISION,
  error TEXT NOT NULL DEFAULT '',
  worker TEXT NOT NULL DEFAULT '',
  created_at DOUBLE PRECISION NOT NULL,
  finished_at DOUBLE PRECISION NOT NULL DEFAULT 0,
  finish_seq BIGINT NOT NULL DEFAULT -1,
  finished_before BIGINT NOT NULL DEFAULT 0,
  pending_before BIGINT NOT NULL DEFAULT 0,
  batch_size BIGINT NOT NULL DEFAULT 1,
  batch_index BIGINT NOT NULL DEFAULT 0,
  fit_seconds DOUBLE PRECISION NOT NULL DEFAULT 0,
  acquisition_seconds DOUBLE PRECISION NOT NULL DEFAULT 0,
  evaluation_seconds DOUBLE PRECISION NOT NULL DEFAULT 0,
  PRIMARY KEY (study, id)
);
CREATE INDEX IF NOT EXISTS varbo_trials_state ON varbo_trials (study, state);
CREATE INDEX IF NOT EXISTS varbo_trials_finish_seq ON varbo_trials (study, finish_seq);
CREATE TABLE IF NOT EXISTS varbo_snapshots (
  id BIGSERIAL PRIMARY KEY,
  study TEXT NOT NULL REFERENCES varbo_studies (name) ON DELETE CASCADE,
  after_trials BIGINT NOT NULL,
  iteration BIGINT NOT NULL,
  objective DOUBLE PRECISION,
  note TEXT NOT NULL DEFAULT '',
  region_state TEXT NOT NULL DEFAULT '',
  hyperparameters TEXT NOT NULL
);
CREATE INDEX IF NOT EXISTS varbo_snapshots_study ON varbo_snapshots (study, id);
CREATE TABLE IF NOT EXISTS varbo_algorithm_states (
  id BIGSERIAL PRIMARY KEY,
  study TEXT NOT NULL REFERENCES varbo_studies (name) ON DELETE CASCADE,
  finished BIGINT NOT NULL,
  outstanding BIGINT NOT NULL DEFAULT -1,
  state TEXT NOT NULL,
  created_at DOUBLE PRECISION NOT NULL
);
CREATE INDEX IF NOT EXISTS varbo_algorithm_states_study ON varbo_algorithm_states (study, id);
CREATE TABLE IF NOT EXISTS varbo_workers (
  study TEXT NOT NULL REFERENCES varbo_studies (name) ON DELETE CASCADE,
  id TEXT NOT NULL,
  host TEXT NOT NULL,
  pid BIGINT NOT NULL,
  started_at DOUBLE PRECISION NOT NULL,
  heartbeat_at DOUBLE PRECISION NOT NULL,
  state TEXT NOT NULL,
  PRIMARY KEY (study, id)
);
)SQL";

// CREATE ... IF NOT EXISTS would print notices; warnings and errors still reach the exceptions. A lock waited for
// longer than kLockWaitSeconds ends the statement (SQLSTATE 55P03): a transaction waiting for the study's row lock
// then says who may hold it and waits again, instead of waiting in silence for as long as the holder lives (a
// process stopped inside its transaction by Ctrl-Z or SIGSTOP, a suspended host: red team, session 25).
// kLockWaitSeconds is 10, or VARBO_PG_LOCK_WAIT (whole seconds, 1-3600; for tests) when set.
int lock_wait_seconds() {
  static const int seconds = [] {
    const char* env = std::getenv("VARBO_PG_LOCK_WAIT");
    if (!env || !*env) return 10;
    char* end = nullptr;
    const long v = std::strtol(env, &end, 10);
    return *end == '\0' && v >= 1 && v <= 3600 ? static_cast<int>(v) : 10;
  }();
  return seconds;
}
const int kLockWaitSeconds = lock_wait_seconds();
const std::string kQuietNotices =
    fmt::format("SET client_min_messages TO WARNING; SET lock_timeout = '{}s'", kLockWaitSeconds);

constexpr const char* kColumns =
    "id, state, phase, x, theta, cost, components, noiseless_cost, error, worker, created_at, finished_at, "
    "finish_seq, finished_before, pending_before, batch_size, batch_index, fit_seconds, acquisition_seconds, "
    "evaluation_seconds";

/// Doubles travel as text: the shortest representation that reads back bit-identical (fmt's "{}"), NaN as
/// '' (stored NULL, as SQLite stores it). The server prints float8 shortest-exact as well (PostgreSQL ≥ 12).
std::string num(double v) { return std::isnan(v) ? std::string() : fmt::format("{}", v); }
double to_double(const pqxx::field& f) { return f.is_null() ? std::nan("") : strtod_c(f.c_str(), nullptr); }
std::int64_t to_int(const pqxx::field& f) { return f.is_null() ? 0 : std::strtoll(f.c_str(), nullptr, 10); }
std::string to_text(const pqxx::field& f) { return f.is_null() ? std::string() : std::string(f.c_str()); }

std::string cause(const std::exception& e) { return postgres_cause(e); }

}  // namespace

std::string postgres_cause(const std::exception& e) {
  std::string m = e.what();
  while (!m.empty() && (m.back() == '\n' || m.back() == ' ')) m.pop_back();
  for (const char* p : {"FATAL:  ", "ERROR:  "})
    for (auto i = m.find(p); i != std::string::npos; i = m.find(p)) m.erase(i, std::char_traits<char>::length(p));
  for (auto& c : m)
    if (c == '\n') c = ' ';
  return m;
}

bool postgres_refused(const std::exception& e) {
  const std::string m = e.what();
  // libpq has no error codes for a failed connection, only the server's message. A server starting up or shutting
  // down ("the database system is starting up") is transient and stays retried.
  for (const char* refusal : {"authentication failed", "does not exist", "no pg_hba.conf entry", "permission denied",
                              "password is required", "not permitted to log in", "too many connections for role"})
    if (m.find(refusal) != std::string::npos) return true;
  return false;
}

namespace {

class PostgresStore final : public StudyStore {
 public:
  PostgresStore(const PostgresAddress& address, bool create,
                const std::vector<std::pair<std::string, std::string>>& meta)
      : address_(address) {
    // A connection this process kept from an earlier open of the same address saves connecting (~25 ms).
    conn_ = detail::take_kept_connection(address_.conninfo);
    bool kept = conn_ != nullptr;
    if (!kept) connect(create);
    guarded("open", [&] {
      // Opening takes locks too (creation's rows, a first creation's tables): a deadlock or serialization
      // failure there is retried like any transaction's, with backoff.
      for (int attempt = 1;; ++attempt) {
        try {
          reconnect_if_needed();
          if (create)
            create_study(meta);
          else
            check_study(!kept);
          return;
        } catch (const pqxx::broken_connection&) {
          if (!kept) throw;
          // The kept connection was ended by the server while idle (a restart, pg_terminate_backend, an idle
          // timeout): nothing was sent on it that could have been written, so open once more on a new one.
          kept = false;
          conn_.reset();
          connect(create);
        } catch (const pqxx::transaction_rollback& e) {
          if (attempt >= kRetryAttempts)
            throw InputError(fmt::format("{}: cannot open: the database asked {} times to retry ({}); nothing was written",
                                         location(), attempt, cause(e)));
          const int ms = std::min(2000, 20 << std::min(attempt, 7));
          log_debug("{}: open: {}; retrying in {} ms (attempt {})", location(), cause(e), ms, attempt);
          std::this_thread::sleep_for(std::chrono::milliseconds(jitter(ms)));
        }
      }
    });
  }

  /// The connection goes back to the process's pool for the next open of this address (connection_pool.hpp),
  /// unless it is broken or inside a transaction (neither happens once a store's calls have returned).
  ~PostgresStore() override {
    if (conn_ && !tx_ && conn_->is_open()) detail::keep_connection(address_.conninfo, std::move(conn_));
  }
  PostgresStore(const PostgresStore&) = delete;
  PostgresStore& operator=(const PostgresStore&) = delete;

  const std::string& location() const override { return address_.display; }

  void transaction(const std::function<void()>& body) override {
    if (tx_) {  // join the outer transaction
      body();
      return;
    }
    prefetched_.clear();
    int waits = 0;  // timed-out waits for the study's lock (kLockWaitSeconds each)
    for (int attempt = 1;; ++attempt) {
      tx_next_finish_seq_.reset();
      try {
        reconnect_if_needed();
        pqxx::work w(*conn_, "varbo");
        Current current(tx_, w);
        // The study's row lock: one writer per study at a time (the same guarantee as SQLite's BEGIN IMMEDIATE).
        // NO KEY UPDATE, not UPDATE: the foreign-key checks of a heartbeat's upsert (KEY SHARE) do not wait for it.
        if (w.exec_params("SELECT 1 FROM varbo_studies WHERE name = $1 FOR NO KEY UPDATE", address_.study).empty())
          throw InputError(fmt::format("{}: the study was deleted from the database", location()));
        body();
        current.release();
        w.commit();
        return;
      } catch (const pqxx::transaction_rollback& e) {  // serialization failure, deadlock: the server asks to retry
        if (attempt >= kRetryAttempts)
          throw InputError(fmt::format("{}: the transaction failed {} times ({}); nothing of it was written", location(),
                                       attempt, cause(e)));
        const int ms = std::min(2000, 20 << std::min(attempt, 7));
        log_debug("{}: {}; retrying in {} ms (attempt {})", location(), cause(e), ms, attempt);
        std::this_thread::sleep_for(std::chrono::milliseconds(jitter(ms)));
      } catch (const pqxx::in_doubt_error& e) {
        conn_.reset();
        throw StoreConnectionError(fmt::format("{}: the connection was lost while committing ({}); the transaction may or may "
                                     "not have been written: check with `varbo status {}`",
                                     location(), cause(e), location()));
      } catch (const pqxx::broken_connection& e) {
        conn_.reset();  // a dead connection can still report itself open: the next call connects anew
        throw StoreConnectionError(fmt::format("{}: lost the connection to the database server ({}); the transaction was "
                                     "rolled back, nothing of it was written",
                                     location(), cause(e)));
      } catch (const pqxx::sql_error& e) {
        if (e.sqlstate() == "55P03") {  // lock_timeout: the study's lock is held; say by whom (maybe), wait again
          ++waits;
          --attempt;  // waiting for a holder is not a failed attempt
          if (waits == 1 || waits % std::max(1, 60 / kLockWaitSeconds) == 0) report_lock_wait(waits * kLockWaitSeconds);
          continue;
        }
        throw InputError(fmt::format("{}: database error ({}); the transaction was rolled back, nothing of it was "
                                     "written",
                                     location(), cause(e)));
      } catch (const pqxx::failure& e) {
        throw InputError(fmt::format("{}: database error ({}); nothing of the transaction was written", location(),
                                     cause(e)));
      }
    }
  }

  /// Said while a transaction waits for the study's lock: the sessions of this database holding a transaction open
  /// (one of them holds it), how long, and what ends a stopped holder's hold.
  void report_lock_wait(int seconds) const {
    std::string holders;
    try {
      pqxx::nontransaction n(*conn_);
      const pqxx::result r = n.exec(
          "SELECT pid, application_name, COALESCE(host(client_addr), 'a local socket'), state, "
          "floor(extract(epoch FROM now() - xact_start))::bigint FROM pg_stat_activity WHERE datname = "
          "current_database() AND pid <> pg_backend_pid() AND xact_start IS NOT NULL ORDER BY xact_start LIMIT 5");
      for (const auto& row : r)
        holders += fmt::format("{}server session {} ('{}', from {}, {}, transaction open {} s)", holders.empty() ? "" : "; ",
                               row[0].c_str(), row[1].c_str(), row[2].c_str(), row[3].c_str(), row[4].c_str());
    } catch (const std::exception&) {
      // Only the message loses detail.
    }
    log_warn("{}: waiting {} s for the study's lock, held by another process's transaction{}. A long model fit "
             "holds it for its duration; a process stopped inside its transaction (Ctrl-Z, SIGSTOP, a suspended or "
             "disconnected host) holds it until it continues or its session ends: `kill -CONT` it, or end its "
             "session with SELECT pg_terminate_backend(PID) (its transaction is rolled back, nothing half-written)",
             location(), seconds, holders.empty() ? std::string() : " (open transactions: " + holders + ")");
  }

  std::optional<std::string> meta(const std::string& key) const override {
    if (!tx_) {  // an entry read by the open (check_study), handed out once
      const auto it = prefetched_.find(key);
      if (it != prefetched_.end()) {
        std::optional<std::string> v = std::move(it->second);
        prefetched_.erase(it);
        return v;
      }
    }
    prefetched_.clear();
    return read("read meta", [&](pqxx::transaction_base& t) -> std::optional<std::string> {
      const auto r = t.exec_params("SELECT value FROM varbo_meta WHERE study = $1 AND key = $2", address_.study, key);
      if (r.empty()) return std::nullopt;
      return to_text(r[0][0]);
    });
  }
  void set_meta(const std::string& key, const std::string& value) override {
    prefetched_.clear();
    write([&](pqxx::transaction_base& t) {
      t.exec_params("INSERT INTO varbo_meta (study, key, value) VALUES ($1, $2, $3) "
                    "ON CONFLICT (study, key) DO UPDATE SET value = excluded.value",
                    address_.study, key, value);
    });
  }

  std::vector<TrialRecord> trials() const override { return select_trials("ORDER BY id", std::nullopt); }
  std::optional<TrialRecord> trial(std::int64_t id) const override {
    auto v = select_trials("AND id = $2", id);
    if (v.empty()) return std::nullopt;
    return v.front();
  }
  std::vector<TrialRecord> finished_since(std::int64_t seq) const override {
    return select_trials("AND finish_seq >= $2 AND state IN ('complete', 'failed') ORDER BY finish_seq", seq);
  }
  std::vector<TrialRecord> pending_trials() const override {
    if (!tx_) return select_trials("AND state = 'pending' ORDER BY id", std::nullopt);
    // In a transaction (which holds the study's lock: no other process writes its trials until it ends) the next
    // finish_seq comes along, for next_finish_seq() until this transaction writes a trial: one round trip less
    // for a suggestion. The one-row side keeps that value when nothing is pending.
    return read("read trials", [&](pqxx::transaction_base& t) {
      const pqxx::result r = t.exec_params(std::string("SELECT ") + kColumns +
                                               ", n.next FROM (SELECT COALESCE(MAX(finish_seq) + 1, 0) AS next FROM "
                                               "varbo_trials WHERE study = $1) n LEFT JOIN varbo_trials ON study = $1 "
                                               "AND state = 'pending' ORDER BY id",
                                           address_.study);
      tx_next_finish_seq_ = std::max<std::int64_t>(0, to_int(r[0][20]));
      return trials_of(r);
    });
  }

  std::int64_t add_trial(const TrialRecord& t) override {
    tx_next_finish_seq_.reset();
    std::int64_t id = 0;
    write([&](pqxx::transaction_base& w) {
      // The next id and the insert in one statement (one round trip); the transaction holds the study's lock, so
      // no other writer adds a trial in between. $2 (0) is the id of a study's first trial.
      TrialRecord r = t;
      r.id = 0;
      const pqxx::result res = exec_trial(
          w,
          std::string("INSERT INTO varbo_trials (study, ") + kColumns +
              ") VALUES ($1, COALESCE((SELECT MAX(id) + 1 FROM varbo_trials WHERE study = $1), $2), $3, $4, $5, $6, "
              "NULLIF($7, '')::float8, $8, NULLIF($9, '')::float8, $10, $11, $12, $13, $14, $15, $16, $17, $18, $19, "
              "$20, $21) RETURNING id",
          r);
      id = to_int(res[0][0]);
    });
    return id;
  }

  void update_trial(const TrialRecord& t) override {
    tx_next_finish_seq_.reset();
    write([&](pqxx::transaction_base& w) {
      const auto r = exec_trial(w,
                                std::string("UPDATE varbo_trials SET (") + kColumns +
                                    ") = ($2, $3, $4, $5, $6, NULLIF($7, '')::float8, $8, NULLIF($9, '')::float8, $10, "
                                    "$11, $12, $13, $14, $15, $16, $17, $18, $19, $20, $21) WHERE study = $1 AND id = $2",
                                t);
      if (r.affected_rows() != 1) throw InputError(fmt::format("{}: no trial with id {}", location(), t.id));
    });
  }

  std::int64_t next_finish_seq() const override {
    if (tx_ && tx_next_finish_seq_) return *tx_next_finish_seq_;
    return read("read trials", [&](pqxx::transaction_base& t) {
      return std::max<std::int64_t>(
          0, to_int(t.exec_params("SELECT COALESCE(MAX(finish_seq) + 1, 0) FROM varbo_trials WHERE study = $1",
                                  address_.study)[0][0]));
    });
  }

  void add_snapshot(const StoredSnapshot& snap) override {
    nlohmann::json h = nlohmann::json::array();
    for (const auto& p : snap.snapshot.hyperparameters) h.push_back({p.name, p.value});
    write([&](pqxx::transaction_base& t) {
      t.exec_params("INSERT INTO varbo_snapshots (study, after_trials, iteration, objective, note, hyperparameters, "
                    "region_state) VALUES ($1, $2, $3, NULLIF($4, '')::float8, $5, $6, $7)",
                    address_.study, snap.after_trials, static_cast<std::int64_t>(snap.snapshot.iteration),
                    num(snap.snapshot.objective), snap.snapshot.note, h.dump(), snap.snapshot.region_state);
    });
  }

  std::vector<StoredSnapshot> snapshots() const override {
    return read("read snapshots", [&](pqxx::transaction_base& t) {
      std::vector<StoredSnapshot> out;
      for (const auto& row : t.exec_params("SELECT after_trials, iteration, objective, note, hyperparameters, "
                                           "region_state FROM varbo_snapshots WHERE study = $1 ORDER BY id",
                                           address_.study)) {
        StoredSnapshot r;
        r.after_trials = to_int(row[0]);
        r.snapshot.iteration = static_cast<Index>(to_int(row[1]));
        r.snapshot.objective = to_double(row[2]);
        r.snapshot.note = to_text(row[3]);
        r.snapshot.region_state = to_text(row[5]);
        nlohmann::json h = nlohmann::json::parse(to_text(row[4]), nullptr, false);
        if (h.is_array())
          for (const auto& p : h)
            if (p.is_array() && p.size() == 2 && p[0].is_string() && p[1].is_number())
              r.snapshot.hyperparameters.push_back({p[0].get<std::string>(), p[1].get<double>()});
        out.push_back(std::move(r));
      }
      return out;
    });
  }

  void add_algorithm_state(const AlgorithmSnapshot& snap) override {
    write([&](pqxx::transaction_base& t) {
      // One statement (one round trip): the DELETE does not see the row its WITH inserts (one snapshot), and
      // that row is not older than the kept window anyway.
      t.exec_params("WITH inserted AS (INSERT INTO varbo_algorithm_states (study, finished, outstanding, state, "
                    "created_at) VALUES ($1, $2, $3, $4, $5)) DELETE FROM varbo_algorithm_states WHERE study = $1 AND "
                    "finished < $6",
                    address_.study, snap.finished, snap.outstanding, snap.state, num(snap.created_at),
                    snap.finished - 2);
    });
  }

  std::vector<AlgorithmSnapshot> algorithm_states() const override {
    return read("read algorithm states", [&](pqxx::transaction_base& t) {
      std::vector<AlgorithmSnapshot> out;
      for (const auto& row : t.exec_params("SELECT finished, outstanding, state, created_at FROM varbo_algorithm_states "
                                           "WHERE study = $1 ORDER BY id DESC",
                                           address_.study)) {
        AlgorithmSnapshot a;
        a.finished = to_int(row[0]);
        a.outstanding = to_int(row[1]);
        a.state = to_text(row[2]);
        a.created_at = to_double(row[3]);
        out.push_back(std::move(a));
      }
      return out;
    });
  }

  /// One upsert, atomic by itself: outside a transaction it takes no study lock, so a heartbeat is never held
  /// up behind another process's model fit. The times are the server's clock (`clock_timestamp()`), not the
  /// worker's: workers on machines whose clocks disagree are still judged by one clock (workers() translates).
  void put_worker(const WorkerRecord& wr) override {
    auto upsert = [&](pqxx::transaction_base& t) {
      t.exec_params("INSERT INTO varbo_workers (study, id, host, pid, started_at, heartbeat_at, state) VALUES "
                    "($1, $2, $3, $4, EXTRACT(EPOCH FROM clock_timestamp()), EXTRACT(EPOCH FROM clock_timestamp()), "
                    "$5) ON CONFLICT (study, id) DO UPDATE SET heartbeat_at = excluded.heartbeat_at, state = "
                    "excluded.state",
                    address_.study, wr.id, wr.host, static_cast<std::int64_t>(wr.pid), wr.state);
    };
    if (tx_)
      upsert(*tx_);
    else
      read("record a heartbeat", [&](pqxx::transaction_base& t) {
        upsert(t);
        return 0;
      });
  }

  /// Times in this machine's clock: the server's, shifted by (this clock − the server's clock) now, so that
  /// `unix_time() − heartbeat_at` is the silence measured by the server alone.
  std::vector<WorkerRecord> workers() const override {
    return read("read workers", [&](pqxx::transaction_base& t) {
      std::vector<WorkerRecord> out;
      const pqxx::result r = t.exec_params(
          "SELECT id, host, pid, started_at, heartbeat_at, state, EXTRACT(EPOCH FROM clock_timestamp()) FROM "
          "varbo_workers WHERE study = $1 ORDER BY started_at",
          address_.study);
      const double shift = r.empty() ? 0.0 : unix_time() - to_double(r[0][6]);
      for (const auto& row : r) {
        WorkerRecord w;
        w.id = to_text(row[0]);
        w.host = to_text(row[1]);
        w.pid = static_cast<long>(to_int(row[2]));
        w.started_at = to_double(row[3]) + shift;
        w.heartbeat_at = to_double(row[4]) + shift;
        w.state = to_text(row[5]);
        out.push_back(std::move(w));
      }
      return out;
    });
  }

  std::optional<double> server_started_at() const override {
    return read("read the server's start time", [&](pqxx::transaction_base& t) {
      return to_double(t.exec("SELECT EXTRACT(EPOCH FROM pg_postmaster_start_time())")[0][0]);
    });
  }

  double server_uptime() const override {
    return read("read the server's start time", [&](pqxx::transaction_base& t) {
      return to_double(t.exec("SELECT EXTRACT(EPOCH FROM clock_timestamp() - pg_postmaster_start_time())")[0][0]);
    });
  }

 private:
  /// Sets the current transaction for the duration of a scope (joined by nested calls and the accessors).
  class Current {
   public:
    Current(pqxx::transaction_base*& slot, pqxx::transaction_base& t) : slot_(slot) { slot_ = &t; }
    ~Current() { release(); }
    void release() { slot_ = nullptr; }

   private:
    pqxx::transaction_base*& slot_;
  };

  static int jitter(int ms) {
    thread_local std::minstd_rand rng(std::random_device{}());
    return ms / 2 + static_cast<int>(rng() % static_cast<unsigned>(ms / 2 + 1));
  }

  /// `set_messages` false: the caller sends kQuietNotices itself (check_study).
  void connect(bool set_messages = true) const {
    try {
      conn_ = std::make_unique<pqxx::connection>(address_.conninfo);
      if (set_messages) {
        pqxx::nontransaction n(*conn_);
        n.exec(kQuietNotices);
      }
    } catch (const pqxx::broken_connection& e) {
      const std::string msg = fmt::format("{}: cannot connect to the database server: {}", location(), cause(e));
      if (postgres_refused(e)) throw InputError(msg);  // not worth retrying: the server said no
      throw StoreConnectionError(msg);
    } catch (const pqxx::failure& e) {
      throw InputError(fmt::format("{}: cannot connect to the database server: {}", location(), cause(e)));
    }
  }

  /// A connection the server dropped (restart, pg_terminate_backend) is opened afresh for the next transaction.
  void reconnect_if_needed() const {
    if (conn_ && conn_->is_open()) return;
    log_warn("{}: reconnecting to the database server", location());
    connect();
  }

  /// Runs a read (or a single autocommitted statement) in the current transaction, else on its own.
  template <class F>
  auto read(const char* what, F&& f) const -> decltype(f(std::declval<pqxx::transaction_base&>())) {
    prefetched_.clear();
    if (tx_) return f(*tx_);
    return guarded(what, [&] {
      reconnect_if_needed();
      pqxx::nontransaction n(*conn_);
      return f(n);
    });
  }

  /// A write joins the current transaction, or is a transaction of its own.
  template <class F>
  void write(F&& f) {
    transaction([&] { f(*tx_); });
  }

  /// Runs `f`, turning libpqxx errors into InputErrors naming the study.
  template <class F>
  auto guarded(const char* what, F&& f) const -> decltype(f()) {
    try {
      return f();
    } catch (const pqxx::broken_connection& e) {
      conn_.reset();  // a dead connection can still report itself open: the next call connects anew
      throw StoreConnectionError(fmt::format("{}: cannot {}: lost the connection to the database server ({})", location(), what,
                                   cause(e)));
    } catch (const pqxx::insufficient_privilege& e) {
      throw InputError(fmt::format("{}: cannot {}: the database role lacks a privilege ({})", location(), what,
                                   cause(e)));
    } catch (const pqxx::failure& e) {
      throw InputError(fmt::format("{}: cannot {}: database error ({})", location(), what, cause(e)));
    }
  }

  pqxx::result exec_trial(pqxx::transaction_base& w, const std::string& sql, const TrialRecord& t) {
    return w.exec_params(sql, address_.study, t.id, state_name(t.state), t.phase, vec_text(t.x), vec_text(t.theta),
                         num(t.cost), components_text(t.components), num(t.noiseless_cost), t.error, t.worker,
                         num(t.created_at), num(t.finished_at), t.finish_seq, t.finished_before, t.pending_before,
                         t.batch_size, t.batch_index, num(t.fit_seconds), num(t.acquisition_seconds),
                         num(t.evaluation_seconds));
  }

  std::vector<TrialRecord> select_trials(const std::string& clause, std::optional<std::int64_t> arg) const {
    return read("read trials", [&](pqxx::transaction_base& t) {
      const std::string sql = std::string("SELECT ") + kColumns + " FROM varbo_trials WHERE study = $1 " + clause;
      return trials_of(arg ? t.exec_params(sql, address_.study, *arg) : t.exec_params(sql, address_.study));
    });
  }

  /// A trial's vector; the message naming the trial is formatted only for a corrupt one.
  Vec trial_vec(const pqxx::field& f, std::int64_t id) const {
    const std::string text = to_text(f);
    if (Vec v; read_number_array(text, v)) return v;
    return text_vec(text, fmt::format("{}: trial {}", location(), id));
  }

  /// Trial rows (kColumns first); a row whose id is NULL (an outer join's empty side) is skipped.
  std::vector<TrialRecord> trials_of(const pqxx::result& r) const {
      std::vector<TrialRecord> out;
      out.reserve(r.size());
      for (const auto& row : r) {
        if (row[0].is_null()) continue;
        TrialRecord x;
        x.id = to_int(row[0]);
        x.state = state_from_name(to_text(row[1]));
        x.phase = to_text(row[2]);
        x.x = trial_vec(row[3], x.id);
        x.theta = trial_vec(row[4], x.id);
        x.cost = to_double(row[5]);
        x.components = text_components(to_text(row[6]));
        x.noiseless_cost = to_double(row[7]);
        x.error = to_text(row[8]);
        x.worker = to_text(row[9]);
        x.created_at = to_double(row[10]);
        x.finished_at = to_double(row[11]);
        x.finish_seq = to_int(row[12]);
        x.finished_before = to_int(row[13]);
        x.pending_before = to_int(row[14]);
        x.batch_size = to_int(row[15]);
        x.batch_index = to_int(row[16]);
        x.fit_seconds = to_double(row[17]);
        x.acquisition_seconds = to_double(row[18]);
        x.evaluation_seconds = to_double(row[19]);
        out.push_back(std::move(x));
      }
      return out;
  }

  /// The tables (made once per database, under an advisory lock so that two first creations do not race) and
  /// the study's row with its meta entries, in one transaction: the study appears complete or not at all.
  void create_study(const std::vector<std::pair<std::string, std::string>>& meta) {
    pqxx::work w(*conn_, "varbo create");
    w.exec_params("SELECT pg_advisory_xact_lock($1)", kCreateLockKey);
    // CREATE INDEX IF NOT EXISTS takes a SHARE lock on its table before it finds the index exists; against runs
    // writing trials and snapshots (ROW EXCLUSIVE, one table after the other) that deadlocked under load. Once the
    // schema is complete, creating a study touches only its own rows.
    if (!schema_complete(w)) w.exec(kSchema);
    if (w.exec_params("INSERT INTO varbo_studies (name, created_at) VALUES ($1, $2) ON CONFLICT (name) DO NOTHING",
                      address_.study, num(unix_time()))
            .affected_rows() != 1)
      throw InputError(fmt::format("{}: a study named '{}' exists already in this database; choose another name or "
                                   "continue it with `varbo suggest`/`varbo worker`",
                                   location(), address_.study));
    auto put = [&](const std::string& k, const std::string& v) {
      w.exec_params("INSERT INTO varbo_meta (study, key, value) VALUES ($1, $2, $3) ON CONFLICT (study, key) DO "
                    "UPDATE SET value = excluded.value",
                    address_.study, k, v);
    };
    put("format", kFormat);
    put("schema_version", std::to_string(kSchemaVersion));
    for (const auto& [k, v] : meta) put(k, v);
    w.commit();
  }

  /// Whether every table and index kSchema declares exists already (names read from kSchema itself).
  static bool schema_complete(pqxx::transaction_base& t) {
    static const std::vector<std::string> names = [] {
      std::vector<std::string> out;
      const std::string schema = kSchema, marker = "IF NOT EXISTS ";
      for (auto i = schema.find(marker); i != std::string::npos; i = schema.find(marker, i)) {
        i += marker.size();
        const auto end = schema.find_first_of(" (\n", i);
        out.push_back(schema.substr(i, end - i));
      }
      return out;
    }();
    std::string list;
    for (const auto& n : names) list += (list.empty() ? "'" : ",'") + n + "'";
    const auto r = t.exec("SELECT count(*) FROM unnest(ARRAY[" + list + "]) AS n WHERE to_regclass(n) IS NOT NULL");
    return r[0][0].as<std::size_t>() == names.size();
  }

  /// Opening costs one round trip on a kept connection (the study's row with the meta entries that the open and
  /// Study::open read, kept in prefetched_ and handed out once by meta()), two on a new one (the session setting
  /// first: `fresh`). The tables' existence is not asked first (it was a round trip of its own before every open):
  /// a database without them answers "undefined table", and check_study_row then says so.
  void check_study(bool fresh) {
    {
      pqxx::nontransaction n(*conn_);
      if (fresh) n.exec(kQuietNotices);  // a kept connection has it already: its session is this store's kind
      const auto study_and_meta = [&] {
        return n.exec_params(
            "SELECT m.key, m.value FROM varbo_studies s LEFT JOIN varbo_meta m ON m.study = s.name AND m.key IN "
            "('format', 'schema_version', 'config', 'plugin_paths', 'identity', 'domain') WHERE s.name = $1",
            address_.study);
      };
      pqxx::result r;
      try {
        r = study_and_meta();
      } catch (const pqxx::undefined_table&) {
        check_study_row(n);  // no tables at all: "the database holds no varbo studies"
        throw;               // some of them: the database error as it is
      }
      if (r.empty()) {  // no such study: the message lists the studies there (unless it was created just now)
        check_study_row(n);
        r = study_and_meta();
      }
      prefetched_.clear();
      for (const char* k : {"format", "schema_version", store_key::kConfig, store_key::kPluginPaths,
                            store_key::kIdentity, store_key::kDomain})
        prefetched_[k] = std::nullopt;
      for (const auto& row : r)
        if (!row[0].is_null()) prefetched_[to_text(row[0])] = to_text(row[1]);
    }
    check_meta();
  }

  void check_study_row(pqxx::nontransaction& n) {
    if (to_text(n.exec("SELECT to_regclass('varbo_studies')::text")[0][0]).empty())
      throw InputError(fmt::format("{}: no study named '{}': the database holds no varbo studies (create one with "
                                   "`varbo study create '{}' CONFIG.yaml`)",
                                   location(), address_.study, location()));
    if (n.exec_params("SELECT 1 FROM varbo_studies WHERE name = $1", address_.study).empty()) {
      std::string names;
      int count = 0;
      for (const auto& row : n.exec("SELECT name FROM varbo_studies ORDER BY name LIMIT 11")) {
        names += (count > 0 ? ", " : "") + (count >= 10 ? std::string("...") : to_text(row[0]));
        ++count;
      }
      throw InputError(fmt::format("{}: no study named '{}' in this database (studies there: {}); create it with "
                                   "`varbo study create '{}' CONFIG.yaml`",
                                   location(), address_.study, names.empty() ? "none" : names, location()));
    }
  }

  void check_meta() {
    const auto format = meta("format");
    if (format.value_or("") != kFormat)
      throw InputError(fmt::format("{}: not a varbo study (meta 'format' is '{}', expected '{}')", location(),
                                   format.value_or(""), kFormat));
    const auto v = meta("schema_version");
    const int version = store_codec::schema_version_of(v);
    if (version < 1)
      throw InputError(fmt::format("{}: corrupt varbo study (schema_version '{}')", location(), v.value_or("")));
    if (version > kSchemaVersion)
      throw InputError(fmt::format("{}: written by a newer varbo (store schema version {}; this varbo reads up to "
                                   "version {}); upgrade varbo to open it",
                                   location(), version, kSchemaVersion));
  }

  PostgresAddress address_;
  mutable std::unique_ptr<pqxx::connection> conn_;  // reopened by reads too, after the server dropped it
  /// Meta entries read with the open, each handed out once by meta() outside a transaction: as if those reads had
  /// been made at the open. Any other use of the store (a transaction, another read) forgets them.
  mutable std::map<std::string, std::optional<std::string>> prefetched_;
  /// next_finish_seq() of the current transaction, read by pending_trials(); forgotten when it writes a trial.
  mutable std::optional<std::int64_t> tx_next_finish_seq_;
  pqxx::transaction_base* tx_ = nullptr;
};

}  // namespace

std::unique_ptr<detail::DatabaseLockSession> take_postgres_run_lock(const std::string& url);  // store_postgres_lock.cpp

}  // namespace varbo

/// The entry point libvarbo_study looks up when it loads this library (postgres_backend.cpp).
extern "C" __attribute__((visibility("default"))) const varbo::detail::PostgresBackend*
varbo_study_postgres_backend() {
  static const varbo::detail::PostgresBackend backend = [] {
    varbo::detail::PostgresBackend b;
    b.create = [](const std::string& url, const std::vector<std::pair<std::string, std::string>>& meta)
        -> std::unique_ptr<varbo::StudyStore> {
      return std::make_unique<varbo::PostgresStore>(varbo::parse_postgres_address(url), true, meta);
    };
    b.open = [](const std::string& url) -> std::unique_ptr<varbo::StudyStore> {
      return std::make_unique<varbo::PostgresStore>(varbo::parse_postgres_address(url), false,
                                                    std::vector<std::pair<std::string, std::string>>{});
    };
    b.take_run_lock = &varbo::take_postgres_run_lock;
    return b;
  }();
  return &backend;
}
