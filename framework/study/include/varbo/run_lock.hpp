#pragma once
// One writer per run folder and study: `varbo run` holds an advisory lock (flock) on a small file beside the
// study store for its whole life. SQLite's own locking is per transaction and cannot keep a second driver
// out between trials; `varbo study suggest/observe` take no such lock, so external workers stay concurrent.
#include <memory>
#include <string>

namespace varbo {

class RunLock {
 public:
  /// Takes the exclusive lock on `lock_path` (created if missing) and writes the owner (pid, host, start
  /// time) into it. When another process holds it, throws InputError naming `what`, the owner and the file.
  /// The lock dies with the process (even on SIGKILL); the descriptor is not inherited by child commands.
  static RunLock acquire(const std::string& lock_path, const std::string& what);
  /// The owner line written in a held lock file ("" when unreadable).
  static std::string owner_of(const std::string& lock_path);
  /// Whether a process holds the lock on `lock_path` now (a live `varbo run`); takes nothing.
  static bool held(const std::string& lock_path);
  /// The lock file of the study file `store`: beside the file links lead to, so that a study named through a
  /// link (`run --resume link.db`) is locked as the study it is (two drivers ran at once; red team, session 34).
  static std::string lock_file_of(const std::string& store);

  RunLock(RunLock&& other) noexcept;
  RunLock& operator=(RunLock&& other) noexcept;
  RunLock(const RunLock&) = delete;
  RunLock& operator=(const RunLock&) = delete;
  ~RunLock();  ///< removes the file, then releases the lock

  const std::string& path() const { return path_; }

 private:
  RunLock(int fd, std::string path);
  int fd_ = -1;
  std::string path_;
};

/// The same one-writer rule for a study in a PostgreSQL database, where no lock file can be shared: a
/// session-level advisory lock (`pg_try_advisory_lock`) keyed by the study's name, held by a connection of its
/// own for the lock's life (the store's connection may be dropped and reopened; a lock on it would vanish
/// silently). The server releases it when the session ends, however it ends (SIGKILL, a lost connection).
class DatabaseRunLock {
 public:
  /// Takes the lock of the study at `url`; when another session holds it, throws InputError naming the study
  /// (password hidden) and the owner (pid, host and start of the holding `varbo run`, as it announced itself in its session's
  /// application_name, and the server's backend pid). Connection errors are InputErrors naming the study.
  static DatabaseRunLock acquire(const std::string& url);

  DatabaseRunLock(DatabaseRunLock&&) noexcept;
  DatabaseRunLock& operator=(DatabaseRunLock&&) noexcept;
  ~DatabaseRunLock();  ///< closes the session, which releases the lock

  /// Whether the lock's session still lives (one round trip): false after the server restarted or the connection
  /// was cut, when the server has released the lock and another run could take it.
  bool held() const;

  struct Session;

 private:
  explicit DatabaseRunLock(std::unique_ptr<Session> session);
  std::unique_ptr<Session> session_;
};

}  // namespace varbo
