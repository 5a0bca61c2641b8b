#pragma once
// Test and benchmark helpers: which processes a command started (it writes their pids to a file) and whether they still run.
#include <signal.h>
#include <sys/types.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace varbo::test {

/// The pids a command wrote to `file`, one a line.
inline std::vector<pid_t> pids_in(const std::string& file) {
  std::vector<pid_t> out;
  std::ifstream in(file);
  for (long p; in >> p;) out.push_back(static_cast<pid_t>(p));
  return out;
}

/// Alive and not a zombie (a zombie has ended; only its parent's wait is missing).
inline bool alive(pid_t pid) {
  if (::kill(pid, 0) != 0) return false;
  std::ifstream f("/proc/" + std::to_string(pid) + "/stat");
  std::string s;
  std::getline(f, s);
  const auto p = s.rfind(')');
  return p == std::string::npos || p + 2 >= s.size() || s[p + 2] != 'Z';
}

/// Live processes (not zombies) other than this one whose command line holds `marker`, from /proc.
inline std::vector<pid_t> processes_with(const std::string& marker) {
  std::vector<pid_t> out;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator("/proc", ec)) {
    const std::string name = e.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    const pid_t pid = static_cast<pid_t>(std::stol(name));
    if (pid == ::getpid()) continue;
    std::ifstream f(e.path() / "cmdline", std::ios::binary);
    const std::string cmdline((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    if (cmdline.find(marker) != std::string::npos && alive(pid)) out.push_back(pid);
  }
  return out;
}

}  // namespace varbo::test
