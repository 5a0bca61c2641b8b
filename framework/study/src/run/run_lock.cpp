#include "varbo/run_lock.hpp"

#include <fcntl.h>
#include <signal.h>
#include <fmt/format.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "owner_identity.hpp"
#include "store_guard.hpp"
#include "varbo/errors.hpp"
#include "varbo/held_locks.hpp"
#include "varbo/regular_file.hpp"

namespace varbo {

namespace {

std::string owner_line() {
  // The program's name too: the holder may be `varbo run`, a worker or a Python `varbo.minimize` (python3).
  return fmt::format("{} pid {} on host {}, started {}", detail::run_owner_program(), static_cast<long>(getpid()),
                     detail::machine_name(), detail::utc_timestamp());
}

/// When the owner line names a process of this host that has ended, the lock is held by what it started: a
/// killed run's trial supervisor stopping its last command (held_locks.hpp). Said, so that the message does not
/// name a process that does not exist as the holder (red team, session 34).
std::string owner_gone_note(const std::string& owner) {
  const auto at = owner.find(" pid "), on = owner.find(" on host ");
  if (at == std::string::npos || on == std::string::npos || on < at) return "";
  const std::string pid_text = owner.substr(at + 5, on - at - 5);
  const auto comma = owner.find(',', on);
  const std::string host = owner.substr(on + 9, comma == std::string::npos ? std::string::npos : comma - on - 9);
  if (pid_text.empty() || pid_text.find_first_not_of("0123456789") != std::string::npos || pid_text.size() > 9 ||
      host != detail::machine_name())
    return "";
  const pid_t pid = static_cast<pid_t>(std::stol(pid_text));
  if (::kill(pid, 0) == 0 || errno != ESRCH) return "";
  return fmt::format("; that process has ended, and a process it started still holds the lock (a trial's "
                     "command being stopped within its grace period): try again in a few seconds");
}

}  // namespace

std::string RunLock::owner_of(const std::string& lock_path) {
  if (!absent_or_regular_file(lock_path)) return "";  // a FIFO would block
  std::ifstream in(lock_path);
  std::string line;
  std::getline(in, line);
  return line;
}

std::string RunLock::lock_file_of(const std::string& store) {
  std::error_code ec;
  const std::filesystem::path real = std::filesystem::weakly_canonical(store, ec);
  return (ec ? store : real.string()) + ".lock";
}

bool RunLock::held(const std::string& lock_path) {
  // A run whose lock file was deleted still holds its store's guard (store_guard.hpp).
  const std::string suffix = ".lock";
  if (lock_path.size() > suffix.size() && lock_path.compare(lock_path.size() - suffix.size(), suffix.size(), suffix) == 0 &&
      detail::StoreGuard::held(lock_path.substr(0, lock_path.size() - suffix.size())))
    return true;
  const int fd = ::open(lock_path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK);
  if (fd < 0) return false;  // no lock file: no run
  const bool busy = flock(fd, LOCK_SH | LOCK_NB) != 0 && errno == EWOULDBLOCK;
  ::close(fd);  // releases the shared lock if it was taken
  return busy;
}

RunLock RunLock::acquire(const std::string& lock_path, const std::string& what) {
  // The holder removes the file when it ends; a process that opened the old file just before must not take
  // a lock on a removed inode, hence the check that the locked file is still the one at `lock_path`.
  for (int attempt = 0; attempt < 20; ++attempt) {
    // O_NOFOLLOW: the lock file is truncated and written, and removed at the end; through a symlink planted in
    // a run folder (copied from elsewhere, or hostile) that clobbered the link's target (as root: any file).
    // O_NONBLOCK: a FIFO in its place must not block the open.
    const int fd = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK, 0644);
    if (fd < 0 && errno == ELOOP)
      throw InputError(fmt::format("{}: the lock file is a symbolic link; a lock file must be a plain file (remove "
                                   "the link)",
                                   lock_path));
    if (fd < 0 && errno == EACCES) {
      // The file of another user's run (root's `--resume` in a user's folder), left by a kill: it blocked the
      // folder's owner for good ("cannot create the lock file: Permission denied", red team, session 28). Locked
      // by nobody, it is stale: removed (the folder is ours to write), and the loop makes our own.
      struct stat st {};
      const bool have_stat = ::stat(lock_path.c_str(), &st) == 0;
      const int ro = ::open(lock_path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK);
      if (ro >= 0) {
        const bool free = flock(ro, LOCK_EX | LOCK_NB) == 0;
        const int err = errno;
        const bool removed = free && ::unlink(lock_path.c_str()) == 0;
        ::close(ro);
        if (removed) continue;
        if (!free && err == EWOULDBLOCK) {
          std::string owner = owner_of(lock_path);
          throw InputError(fmt::format("{} is in use by another run ({}); wait for it to end or stop it; only one "
                                       "run may drive a study (lock file {})",
                                       what, owner.empty() ? "another user's process" : owner, lock_path));
        }
      }
      // No lock file at all: the folder is what this user may not write (red team, session 29: told to remove a
      // file that did not exist).
      if (!have_stat)
        throw InputError(fmt::format("{}: cannot create the lock file: its folder is not writable by this user "
                                     "(Permission denied); a run writes its files there: run as the folder's owner, "
                                     "or make it group-writable",
                                     lock_path));
      throw InputError(fmt::format("{}: the lock file (owned by uid {}) is not writable by this user; if no varbo "
                                   "runs on this folder it is stale: remove it",
                                   lock_path, st.st_uid));
    }
    if (fd < 0) {
      const int err = errno;
      // As `varbo worker` says it (red team, session 46: `run --resume` on a read-only mount said only "cannot
      // create the lock file: Read-only file system").
      if (err == EROFS)
        throw InputError(fmt::format("{} is on a read-only file system: it can be read (varbo status, "
                                     "export, select, plot) but not run or changed; copy the run folder to a "
                                     "writable place and resume the copy (cannot create the lock file {})",
                                     what, lock_path));
      throw InputError(fmt::format("{}: cannot create the lock file: {}", lock_path, std::strerror(err)));
    }
    struct stat kind {};
    if (fstat(fd, &kind) != 0 || !S_ISREG(kind.st_mode)) {
      ::close(fd);
      throw InputError(fmt::format("{}: the lock file is not a plain file (a FIFO, device or socket?); remove it",
                                   lock_path));
    }
    if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int err = errno;
      ::close(fd);
      if (err != EWOULDBLOCK)
        throw InputError(fmt::format("{}: cannot lock: {}", lock_path, std::strerror(err)));
      std::string owner = owner_of(lock_path);
      if (owner.empty()) owner = "another process (starting up)";
      throw InputError(fmt::format("{} is in use by another run ({}){}; wait for it to end or stop it; "
                                   "only one run may drive a study (lock file {})",
                                   what, owner, owner_gone_note(owner), lock_path));
    }
    struct stat held {}, named {};
    if (fstat(fd, &held) != 0 || lstat(lock_path.c_str(), &named) != 0 || held.st_ino != named.st_ino ||
        held.st_dev != named.st_dev) {
      ::close(fd);  // removed or replaced between open and flock: try the current file
      continue;
    }
    const std::string line = owner_line() + "\n";
    if (ftruncate(fd, 0) != 0 || ::write(fd, line.data(), line.size()) != static_cast<ssize_t>(line.size())) {
      // The lock holds without the owner line; only the message of a second run is poorer.
    }
    return RunLock(fd, lock_path);
  }
  throw InputError(fmt::format("{}: the lock file keeps changing; is another run starting and stopping?", lock_path));
}

RunLock::RunLock(RunLock&& other) noexcept : fd_(other.fd_), path_(std::move(other.path_)) { other.fd_ = -1; }

RunLock& RunLock::operator=(RunLock&& other) noexcept {
  if (this != &other) {
    this->~RunLock();
    fd_ = other.fd_;
    path_ = std::move(other.path_);
    other.fd_ = -1;
  }
  return *this;
}

RunLock::RunLock(int fd, std::string path) : fd_(fd), path_(std::move(path)) { hold_lock_in_trials(fd_); }

RunLock::~RunLock() {
  if (fd_ < 0) return;
  release_lock_from_trials(fd_);
  ::unlink(path_.c_str());  // while still holding the lock: see acquire()
  ::close(fd_);
  fd_ = -1;
}

}  // namespace varbo
