#include "trial_cgroup.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <signal.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>
#include <thread>
#include <vector>

#include "signal_safe_text.hpp"

namespace varbo::tasks {

// ---------------------------------------------------------------------------------------------------------
// Async-signal-safe part.

namespace cgroup_raw {
namespace {
ssize_t write_text(int dir_fd, const char* file, const char* text, std::size_t n) {
  const int fd = ::openat(dir_fd, file, O_WRONLY | O_CLOEXEC);
  if (fd < 0) return -1;
  ssize_t w;
  do {
    w = ::write(fd, text, n);
  } while (w < 0 && errno == EINTR);
  const int saved = errno;
  ::close(fd);
  errno = saved;
  return w;
}
}  // namespace

int enter(int dir_fd) {
  char text[24];
  const int len = signal_safe::decimal(::getpid(), text);
  if (write_text(dir_fd, "cgroup.procs", text, static_cast<std::size_t>(len)) != len) return errno != 0 ? errno : EIO;
  return 0;
}

bool populated(int dir_fd) {
  const int fd = ::openat(dir_fd, "cgroup.events", O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  char buf[256];
  ssize_t got;
  do {
    got = ::read(fd, buf, sizeof buf - 1);
  } while (got < 0 && errno == EINTR);
  ::close(fd);
  if (got <= 0) return false;
  buf[got] = '\0';
  const char* key = "populated ";
  for (const char* p = buf; *p; ++p) {
    const char* a = p;
    const char* k = key;
    while (*k && *a == *k) ++a, ++k;
    if (*k == '\0') return *a == '1';
  }
  return false;
}

int signal_listed(int dir_fd, int sig) {
  const int fd = ::openat(dir_fd, "cgroup.procs", O_RDONLY | O_CLOEXEC);
  if (fd < 0) return 0;
  char buf[4096];
  long pid = 0;
  bool in_number = false;
  int count = 0;
  auto send = [&] {
    if (in_number && pid > 0) {
      ::kill(static_cast<pid_t>(pid), sig);
      if (sig == SIGTERM) ::kill(static_cast<pid_t>(pid), SIGCONT);  // a stopped process must run to see it
      ++count;
    }
    pid = 0;
    in_number = false;
  };
  for (;;) {
    const ssize_t got = ::read(fd, buf, sizeof buf);
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) break;
    for (ssize_t i = 0; i < got; ++i) {
      if (buf[i] >= '0' && buf[i] <= '9') {
        if (pid < 0x3fffffff) pid = pid * 10 + (buf[i] - '0');
        in_number = true;
      } else {
        send();
      }
    }
  }
  send();
  ::close(fd);
  return count;
}

void kill_all(int dir_fd) {
  if (write_text(dir_fd, "cgroup.kill", "1", 1) == 1) return;
  // Before Linux 5.14: frozen processes cannot fork, so a list read while frozen is complete; a frozen process
  // still dies of SIGKILL. Without cgroup.freeze (before 5.2) the list is re-read until empty by the caller.
  const bool frozen = write_text(dir_fd, "cgroup.freeze", "1", 1) == 1;
  if (frozen) {
    // Freezing is asynchronous ("frozen 1" in cgroup.events once done); SIGKILL works either way, and a
    // process forked meanwhile is caught by the caller's next round.
    timespec ts{0, 2 * 1000000L};
    ::nanosleep(&ts, nullptr);
  }
  signal_listed(dir_fd, SIGKILL);
  if (frozen) write_text(dir_fd, "cgroup.freeze", "0", 1);
}
}  // namespace cgroup_raw

// ---------------------------------------------------------------------------------------------------------

namespace {

// "\040" (space) and the like in a mountinfo path.
std::string unescape_mount_path(const std::string& s) {
  const auto oct = [](char c) { return c >= '0' && c <= '7'; };
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '\\' && i + 3 < s.size() && oct(s[i + 1]) && oct(s[i + 2]) && oct(s[i + 3])) {
      out += static_cast<char>((s[i + 1] - '0') * 64 + (s[i + 2] - '0') * 8 + (s[i + 3] - '0'));
      i += 3;
      continue;
    }
    out += s[i];
  }
  return out;
}

bool pid_gone(long pid) { return ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH; }

// rmdir of `path` and of every directory below it, deepest first (a cgroup's own files go with it).
bool remove_cgroup_tree(const std::string& path) {
  if (DIR* d = ::opendir(path.c_str())) {
    std::vector<std::string> subdirs;
    while (const dirent* e = ::readdir(d)) {
      if (e->d_type != DT_DIR || std::strcmp(e->d_name, ".") == 0 || std::strcmp(e->d_name, "..") == 0) continue;
      subdirs.push_back(path + "/" + e->d_name);
    }
    ::closedir(d);
    for (const auto& s : subdirs) remove_cgroup_tree(s);
  }
  return ::rmdir(path.c_str()) == 0 || errno == ENOENT;
}

// Empty trial cgroups of varbo processes that are gone (killed by SIGKILL together with their supervisors).
// A populated one is left alone: its processes are not ours to kill, and another varbo may share the pid in
// another pid namespace.
void remove_stale(const std::string& home) {
  DIR* d = ::opendir(home.c_str());
  if (d == nullptr) return;
  std::vector<std::string> stale;
  const std::size_t plen = std::strlen(kTrialCgroupPrefix);
  while (const dirent* e = ::readdir(d)) {
    if (e->d_type != DT_DIR || std::strncmp(e->d_name, kTrialCgroupPrefix, plen) != 0) continue;
    char* end = nullptr;
    const long pid = std::strtol(e->d_name + plen, &end, 10);
    if (pid <= 0 || end == nullptr || *end != '-' || pid == ::getpid() || !pid_gone(pid)) continue;
    stale.push_back(home + "/" + e->d_name);
  }
  ::closedir(d);
  for (const auto& s : stale) {
    const int fd = ::open(s.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) continue;
    const bool busy = cgroup_raw::populated(fd);
    ::close(fd);
    if (!busy) remove_cgroup_tree(s);
  }
}

CgroupHome resolve_home() {
  CgroupHome h;
  std::ifstream cg("/proc/self/cgroup");
  if (!cg) {
    h.why = "/proc/self/cgroup cannot be read";
    return h;
  }
  std::string line, rel;
  bool v2 = false;
  while (std::getline(cg, line))
    if (line.rfind("0::", 0) == 0) {
      rel = line.substr(3);
      v2 = true;
    }
  if (!v2) {
    h.why = "no cgroup v2 hierarchy (/proc/self/cgroup has no 0:: line: cgroup v1 only)";
    return h;
  }
  if (rel.empty() || rel[0] != '/' || rel.find(" (deleted)") != std::string::npos) {
    h.why = fmt::format("varbo's cgroup v2 path '{}' is not usable", rel);
    return h;
  }
  std::ifstream mi("/proc/self/mountinfo");
  std::string best_dir;
  while (std::getline(mi, line)) {
    const auto dash = line.find(" - ");
    if (dash == std::string::npos) continue;
    std::istringstream after(line.substr(dash + 3));
    std::string fstype;
    after >> fstype;
    if (fstype != "cgroup2") continue;
    std::istringstream before(line.substr(0, dash));
    std::string id, parent, devno, root, mount_point;
    before >> id >> parent >> devno >> root >> mount_point;
    root = unescape_mount_path(root);
    mount_point = unescape_mount_path(mount_point);
    // The mount shows the hierarchy from `root`; varbo's cgroup must lie at or below it.
    std::string below;
    if (root == "/") below = rel;
    else if (rel == root) below = "/";
    else if (rel.rfind(root + "/", 0) == 0) below = rel.substr(root.size());
    else continue;
    best_dir = mount_point + (below == "/" ? "" : below);
    break;
  }
  if (best_dir.empty()) {
    h.why = fmt::format("no cgroup2 file system mounted that shows varbo's cgroup '{}' (/proc/self/mountinfo)", rel);
    return h;
  }
  struct stat st{};
  if (::stat(best_dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) {
    h.why = fmt::format("varbo's cgroup directory {} does not exist ({})", best_dir, std::strerror(errno));
    return h;
  }
  h.dir = best_dir;
  remove_stale(h.dir);
  return h;
}

std::string new_name() {
  static std::atomic<unsigned long> counter{0};
  static const unsigned long salt = std::random_device{}() & 0xffffu;
  return fmt::format("{}{}-{}-{:x}", kTrialCgroupPrefix, static_cast<long>(::getpid()), counter.fetch_add(1), salt);
}

}  // namespace

const CgroupHome& cgroup_home() {
  static const CgroupHome home = resolve_home();
  return home;
}

const std::string& cgroup_unavailable() {
  static const std::string why = [] {
    TrialCgroup probe;
    std::string reason;
    if (!probe.create(reason)) return reason;
    probe.remove();
    return std::string();
  }();
  return why;
}

bool TrialCgroup::create(std::string& why) {
  remove();
  const CgroupHome& home = cgroup_home();
  if (home.dir.empty()) {
    why = home.why;
    return false;
  }
  const std::string path = home.dir + "/" + new_name();
  if (::mkdir(path.c_str(), 0755) != 0) {
    why = fmt::format("cannot make a cgroup in {}: {}", home.dir, std::strerror(errno));
    return false;
  }
  const int fd = ::open(path.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) {
    why = fmt::format("cannot open {}: {}", path, std::strerror(errno));
    ::rmdir(path.c_str());
    return false;
  }
  // Its interface files must be writable by us (a cgroupfs mounted read-only fails the mkdir already; a
  // delegated tree may still refuse a file).
  if (::faccessat(fd, "cgroup.procs", W_OK, AT_EACCESS) != 0) {
    why = fmt::format("cannot write {}/cgroup.procs: {}", path, std::strerror(errno));
    ::close(fd);
    ::rmdir(path.c_str());
    return false;
  }
  path_ = path;
  dir_fd_ = fd;
  return true;
}

bool TrialCgroup::remove(double max_seconds) {
  if (dir_fd_ < 0) return true;
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::duration<double>(max_seconds);
  // The kill also reaches cgroups below (a nested varbo's trials): cgroup.kill is recursive, and without it
  // each round kills what is listed here and below.
  for (;;) {
    if (!cgroup_raw::populated(dir_fd_)) break;
    cgroup_raw::kill_all(dir_fd_);
    if (!cgroup_raw::populated(dir_fd_)) break;
    if (DIR* d = ::opendir(path_.c_str())) {  // without cgroup.kill: the cgroups below too
      std::vector<std::string> subs;
      while (const dirent* e = ::readdir(d))
        if (e->d_type == DT_DIR && e->d_name[0] != '.') subs.push_back(path_ + "/" + e->d_name);
      ::closedir(d);
      for (const auto& s : subs) {
        const int fd = ::open(s.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
        if (fd < 0) continue;
        cgroup_raw::kill_all(fd);
        ::close(fd);
      }
    }
    if (std::chrono::steady_clock::now() >= give_up) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ::close(dir_fd_);
  dir_fd_ = -1;
  const bool removed = remove_cgroup_tree(path_);
  path_.clear();
  return removed;
}

}  // namespace varbo::tasks
