#include "varbo/held_locks.hpp"

#include <algorithm>
#include <mutex>

namespace varbo {
namespace {
std::mutex& mutex() {
  static std::mutex m;
  return m;
}
std::vector<int>& fds() {
  static auto* v = new std::vector<int>();  // never destroyed: a RunLock may be released during exit
  return *v;
}
}  // namespace

void hold_lock_in_trials(int fd) {
  std::lock_guard<std::mutex> lock(mutex());
  if (fd >= 0 && static_cast<int>(fds().size()) < kMaxHeldLocks) fds().push_back(fd);
}

void release_lock_from_trials(int fd) {
  std::lock_guard<std::mutex> lock(mutex());
  fds().erase(std::remove(fds().begin(), fds().end(), fd), fds().end());
}

std::vector<int> locks_held_for_trials() {
  std::lock_guard<std::mutex> lock(mutex());
  return fds();
}

}  // namespace varbo
