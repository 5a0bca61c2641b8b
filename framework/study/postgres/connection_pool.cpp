// The process's kept PostgreSQL connections (connection_pool.hpp).
#include "connection_pool.hpp"

#include <pthread.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "varbo/log.hpp"
#include "varbo/numbers.hpp"

namespace varbo::detail {

namespace {

using Clock = std::chrono::steady_clock;

constexpr double kDefaultKeepSeconds = 30;

/// VARBO_PG_KEEP_SECONDS, read at each use (a test or a long program may change it); a value that is not a
/// non-negative number is reported once and the default used.
double keep_seconds() {
  const char* e = std::getenv("VARBO_PG_KEEP_SECONDS");
  if (!e || !*e) return kDefaultKeepSeconds;
  char* end = nullptr;
  const double v = strtod_c(e, &end);
  if (end != e && *end == '\0' && std::isfinite(v) && v >= 0) return v;
  static std::once_flag warned;
  std::call_once(warned, [&] {
    log_warn("VARBO_PG_KEEP_SECONDS='{}' is not a number of seconds >= 0; keeping idle database connections for {} s",
             e, kDefaultKeepSeconds);
  });
  return kDefaultKeepSeconds;
}

struct Kept {
  std::unique_ptr<pqxx::connection> connection;
  Clock::time_point since;
};

std::atomic<bool> pool_destroyed{false};  // after exit's destructors ran: a store closing later closes its connection itself

class Pool {
 public:
  static Pool& instance() {
    static Pool pool;
    return pool;
  }

  std::unique_ptr<pqxx::connection> take(const std::string& conninfo) {
    std::lock_guard<std::mutex> lock(mutex_);
    expire(Clock::now());
    const auto it = kept_.find(conninfo);
    if (it == kept_.end()) return nullptr;
    std::unique_ptr<pqxx::connection> c = std::move(it->second.connection);
    kept_.erase(it);
    return c;
  }

  void keep(const std::string& conninfo, std::unique_ptr<pqxx::connection> c) {
    std::unique_ptr<pqxx::connection> closing;  // closed outside the lock (a round trip to the server)
    {
      std::lock_guard<std::mutex> lock(mutex_);
      const auto now = Clock::now();
      expire(now);
      if (keep_seconds() > 0) {
        Kept& slot = kept_[conninfo];
        closing = std::move(slot.connection);  // one per address: the older one goes
        slot = Kept{std::move(c), now};
      } else {
        closing = std::move(c);
      }
    }
  }

  ~Pool() {
    pool_destroyed = true;
    kept_.clear();  // PQfinish: the server ends the sessions at once, not at its next timeout
  }

 private:
  Pool() { pthread_atfork(&Pool::before_fork, &Pool::after_fork_parent, &Pool::after_fork_child); }

  void expire(Clock::time_point now) {
    const double keep = keep_seconds();
    for (auto it = kept_.begin(); it != kept_.end();) {
      if (std::chrono::duration<double>(now - it->second.since).count() > keep)
        it = kept_.erase(it);
      else
        ++it;
    }
  }

  // A fork while another thread holds the lock would leave the child's copy locked forever: hold it across the
  // fork. The child's copies of the connections share their sockets with the parent's sessions; closing one
  // (PQfinish sends Terminate) would end the parent's session, so the child forgets them without closing.
  static void before_fork() { instance().mutex_.lock(); }
  static void after_fork_parent() { instance().mutex_.unlock(); }
  static void after_fork_child() {
    Pool& p = instance();
    // Never destroyed, and reachable from a global: a leak checker in the child does not report them.
    static auto* forgotten = new std::vector<pqxx::connection*>;
    for (auto& [conninfo, kept] : p.kept_) forgotten->push_back(kept.connection.release());
    p.kept_.clear();
    p.mutex_.unlock();
  }

  std::mutex mutex_;
  std::map<std::string, Kept> kept_;
};

}  // namespace

std::unique_ptr<pqxx::connection> take_kept_connection(const std::string& conninfo) {
  if (pool_destroyed) return nullptr;
  return Pool::instance().take(conninfo);
}

void keep_connection(const std::string& conninfo, std::unique_ptr<pqxx::connection> c) {
  if (!c || pool_destroyed) return;  // `c` closes here
  Pool::instance().keep(conninfo, std::move(c));
}

}  // namespace varbo::detail
