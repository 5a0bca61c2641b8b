// `varbo run`'s one-writer lock on a database study (run_lock.hpp; part of libvarbo_study_postgres.so): a
// session-level advisory lock keyed by the study's name, on a connection of its own. The holder announces itself
// in its session's application_name, so a second run can name it from pg_stat_activity without any row to write
// (or to leave stale after a SIGKILL).
#include <fmt/format.h>
#include <unistd.h>

#include <pqxx/pqxx>

#include "postgres_backend.hpp"
#include "run/owner_identity.hpp"
#include "store_url.hpp"
#include "varbo/held_locks.hpp"
#include "varbo/errors.hpp"

namespace varbo {

namespace {

/// The lock is held as long as this connection is open — in this process or in a trial's supervisor: its socket
/// is kept by the supervisors as a lock file is (held_locks.hpp), so a `varbo run` killed by SIGKILL holds the
/// study until its last command has stopped. Before, the server released the lock with the run's process, and a
/// worker started the same θ while the killed run's command was still stopping (red team, session 49).
struct Session final : detail::DatabaseLockSession {
  pqxx::connection connection;
  int held_fd = -1;
  explicit Session(const std::string& conninfo) : connection(conninfo) {}
  ~Session() override {
    if (held_fd >= 0) release_lock_from_trials(held_fd);
  }
  void hold_in_trials() {
    held_fd = connection.sock();
    hold_lock_in_trials(held_fd);
  }
  bool alive() override {
    try {
      pqxx::nontransaction n(connection);
      n.exec("SELECT 1");
      return true;
    } catch (const std::exception&) {  // a dropped session: the server has released its locks
      return false;
    }
  }
};

// One 64-bit advisory key per study name; the prefix keeps it apart from the key that serializes table creation
// (store_postgres.cpp) and from other applications' keys in the same database.
constexpr const char* kKey = "hashtextextended('varbo run: ' || $1, 0)";

/// "varbo run pid 4711 started 2026-12-02T03:04:05Z host rig-3": at most 63 bytes are kept by the server,
/// so the host, the longest part, comes last.
std::string announcement() {
  return fmt::format("{} pid {} started {} host {}", detail::run_owner_program(), static_cast<long>(getpid()),
                     detail::utc_timestamp(), detail::machine_name());
}

/// The session holding the study's lock, as it announced itself ("" when it is gone or cannot be seen).
std::string owner_of(pqxx::connection& c, const std::string& study) {
  pqxx::nontransaction n(c);
  const pqxx::result r = n.exec_params(
      std::string("SELECT a.pid, a.application_name, COALESCE(host(a.client_addr), 'a local socket') FROM pg_locks l "
                  "JOIN pg_stat_activity a ON a.pid = l.pid WHERE l.locktype = 'advisory' AND l.granted AND "
                  "l.objsubid = 1 AND l.database = (SELECT oid FROM pg_database WHERE datname = current_database()) "
                  "AND ((l.classid::bigint << 32) | l.objid::bigint) = ") +
          kKey,
      study);
  if (r.empty()) return "";
  return fmt::format("{}; server session {} from {}", r[0][1].c_str(), r[0][0].c_str(), r[0][2].c_str());
}

}  // namespace

/// DatabaseRunLock::acquire (run_lock.hpp), through the backend table (postgres_backend.hpp).
std::unique_ptr<detail::DatabaseLockSession> take_postgres_run_lock(const std::string& url) {
  const PostgresAddress address = parse_postgres_address(url);
  std::unique_ptr<Session> s;
  try {
    s = std::make_unique<Session>(address.conninfo);
    bool locked = false;
    {
      pqxx::nontransaction n(s->connection);
      n.exec_params("SELECT set_config('application_name', $1, false)", announcement());
      locked = n.exec_params(std::string("SELECT pg_try_advisory_lock(") + kKey + ")", address.study)[0][0].as<bool>();
    }
    if (locked) {
      s->hold_in_trials();
      return s;
    }
    std::string owner = owner_of(s->connection, address.study);
    if (owner.empty()) owner = "another session, which just ended or cannot be seen";
    throw InputError(fmt::format("the study {} is in use by another run ({}); wait for it to end or stop it; "
                                 "only one run may drive a study (advisory lock on the database server)",
                                 address.display, owner));
  } catch (const pqxx::broken_connection& e) {  // the server is unreachable: worth retrying (store_retry.hpp)
    if (postgres_refused(e))
      throw InputError(fmt::format("{}: cannot take the run lock on the database server: {}", address.display,
                                   postgres_cause(e)));
    throw StoreConnectionError(fmt::format("{}: cannot take the run lock on the database server: {}",
                                           address.display, postgres_cause(e)));
  } catch (const pqxx::failure& e) {
    throw InputError(fmt::format("{}: cannot take the run lock on the database server: {}", address.display,
                                 postgres_cause(e)));
  }
}


}  // namespace varbo
