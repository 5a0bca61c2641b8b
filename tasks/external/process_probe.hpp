#pragma once
// Test helpers: which processes a command started (it writes their pids to a file) and whether they still run.
#include <signal.h>
#include <sys/types.h>

#include <fstream>
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

}  // namespace varbo::test
