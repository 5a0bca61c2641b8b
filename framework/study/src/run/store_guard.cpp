#include "store_guard.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "varbo/errors.hpp"
#include "varbo/held_locks.hpp"

namespace varbo::detail {

namespace {

// 2^62: beyond any SQLite file and far from its lock bytes (PENDING_BYTE 0x40000000 and the 510 bytes after it).
constexpr off_t kGuardByte = static_cast<off_t>(1) << 62;

struct flock guard_range(short type) {
  struct flock fl {};
  fl.l_type = type;
  fl.l_whence = SEEK_SET;
  fl.l_start = kGuardByte;
  fl.l_len = 1;
  fl.l_pid = 0;  // required 0 for OFD locks
  return fl;
}

}  // namespace

StoreGuard StoreGuard::take(const std::string& store, const std::string& what, const std::string& lock_path) {
  // O_NOFOLLOW is not wanted: a study named through a link is guarded as the file it is (as its lock file is).
  // O_NONBLOCK: a FIFO in the store's place must not block (Study::attach then says what it is).
  const int fd = ::open(store.c_str(), O_RDWR | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) return StoreGuard();  // no store yet, or not ours to write: attaching it says so
  struct stat st {};
  if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    return StoreGuard();
  }
  struct flock fl = guard_range(F_WRLCK);
  if (fcntl(fd, F_OFD_SETLK, &fl) == 0) {
    hold_lock_in_trials(fd);  // kept by the trials' supervisors as the run lock is (held_locks.hpp)
    return StoreGuard(fd);
  }
  const int err = errno;
  ::close(fd);
  if (err == EAGAIN || err == EACCES)
    throw InputError(fmt::format("{} is in use by another run, whose lock file {} was removed while it ran (so its "
                                 "owner is not known); wait for it to end or stop it; only one run may drive a study",
                                 what, lock_path));
  return StoreGuard();  // EINVAL and the like: OFD locks unsupported here
}

bool StoreGuard::held(const std::string& store) {
  const int fd = ::open(store.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) return false;
  struct flock fl = guard_range(F_WRLCK);
  const bool busy = fcntl(fd, F_OFD_GETLK, &fl) == 0 && fl.l_type != F_UNLCK;
  ::close(fd);
  return busy;
}

bool StoreGuard::guards(const std::string& store) const {
  if (fd_ < 0) return false;
  struct stat mine {}, named {};
  return fstat(fd_, &mine) == 0 && ::stat(store.c_str(), &named) == 0 && mine.st_ino == named.st_ino &&
         mine.st_dev == named.st_dev;
}

StoreGuard::StoreGuard(StoreGuard&& other) noexcept : fd_(other.fd_) { other.fd_ = -1; }

StoreGuard& StoreGuard::operator=(StoreGuard&& other) noexcept {
  if (this != &other) {
    this->~StoreGuard();
    fd_ = other.fd_;
    other.fd_ = -1;
  }
  return *this;
}

StoreGuard::~StoreGuard() {
  if (fd_ < 0) return;
  release_lock_from_trials(fd_);
  ::close(fd_);  // releases the OFD lock (the last descriptor of its open file in this process)
  fd_ = -1;
}

}  // namespace varbo::detail
