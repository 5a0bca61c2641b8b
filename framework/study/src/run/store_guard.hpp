#pragma once
// A second, path-independent hold on a SQLite study while `varbo run` drives it. The run lock (run_lock.hpp) is a
// flock on a file beside the store, named in its "in use" message; deleted while its run lived (by hand, or by a
// script cleaning `*.lock`), it let a `--resume` create a new file, lock that and drive the study beside the first
// run: a θ evaluated twice, two commands on one rig at once, a row missing from trials.csv (audit, session 44). The
// guard is an open-file-description lock (Linux F_OFD_SETLK) on one byte of the store file itself, far beyond the
// bytes SQLite locks (its lock bytes sit at 1 GiB), so it neither meets SQLite's locks nor is released when SQLite
// closes a descriptor of the same file (an OFD lock belongs to its own open file, not to the process).
#include <string>

namespace varbo::detail {

class StoreGuard {
 public:
  StoreGuard() = default;
  /// Takes the guard of the SQLite file `store` if the file exists (else an empty guard: nothing to protect yet).
  /// When another process holds it, throws InputError naming `what` and `lock_path` (whose owner line is gone). A
  /// file system without OFD locks gives an empty guard: the run lock alone then keeps the rule.
  static StoreGuard take(const std::string& store, const std::string& what, const std::string& lock_path);
  /// Whether a process holds the guard of `store` now; takes nothing.
  static bool held(const std::string& store);
  /// Whether this guard holds the file now at `store` (the same inode).
  bool guards(const std::string& store) const;

  StoreGuard(StoreGuard&& other) noexcept;
  StoreGuard& operator=(StoreGuard&& other) noexcept;
  StoreGuard(const StoreGuard&) = delete;
  StoreGuard& operator=(const StoreGuard&) = delete;
  ~StoreGuard();

 private:
  explicit StoreGuard(int fd) : fd_(fd) {}
  int fd_ = -1;
};

}  // namespace varbo::detail
