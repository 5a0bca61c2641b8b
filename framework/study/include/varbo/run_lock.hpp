#pragma once
// One writer per run folder and study: `varbo run` holds an advisory lock (flock) on a small file beside the
// study store for its whole life. SQLite's own locking is per transaction and cannot keep a second driver
// out between trials; `varbo study suggest/observe` take no such lock, so external workers stay concurrent.
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

  RunLock(RunLock&& other) noexcept;
  RunLock& operator=(RunLock&& other) noexcept;
  RunLock(const RunLock&) = delete;
  RunLock& operator=(const RunLock&) = delete;
  ~RunLock();  ///< removes the file, then releases the lock

  const std::string& path() const { return path_; }

 private:
  RunLock(int fd, std::string path) : fd_(fd), path_(std::move(path)) {}
  int fd_ = -1;
  std::string path_;
};

}  // namespace varbo
