#include "varbo/log.hpp"
#include "varbo/regular_file.hpp"
#include "varbo/text.hpp"

#include <atomic>
#include <cerrno>
#include <cstring>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <set>
#include <utility>

namespace varbo {

namespace {
std::atomic<int> g_level{static_cast<int>(LogLevel::Info)};
std::mutex g_mutex;
std::ofstream& log_file() {
  static std::ofstream f;
  return f;
}
const char* tag(LogLevel l) {
  switch (l) {
    case LogLevel::Debug: return "debug";
    case LogLevel::Info: return "info";
    case LogLevel::Warn: return "warning";
    case LogLevel::Error: return "error";
    default: return "";
  }
}
std::string& log_file_path() {
  static std::string p;
  return p;
}
/// With g_mutex held.
void write_message(LogLevel level, std::string_view raw) {
  const std::string message = hide_url_passwords(raw);
  auto& f = log_file();
  if (f.is_open() && level >= LogLevel::Info) {
    f << "[" << tag(level) << "] " << message << '\n';
    f.flush();
  }
  if (static_cast<int>(level) < g_level.load()) return;
  const std::string shown = terminal_text(message);  // names from a study or a task's output: no escape sequences
  std::fprintf(stderr, "[varbo %s] %s\n", tag(level), shown.c_str());
}
}  // namespace

void set_log_level(LogLevel level) { g_level = static_cast<int>(level); }
LogLevel log_level() { return static_cast<LogLevel>(g_level.load()); }

void set_log_file(const std::string& path) {
  std::lock_guard<std::mutex> lock(g_mutex);
  auto& f = log_file();
  if (f.is_open()) f.close();
  log_file_path() = path;
  if (!path.empty() && !absent_or_regular_file(path)) {
    // A FIFO blocked `run --resume` forever (and SIGTERM with it), a device would take every message (red team,
    // session 34). Said on the terminal; the run goes on.
    if (g_level.load() <= static_cast<int>(LogLevel::Warn))
      std::fprintf(stderr, "[varbo warning] %s: not a regular file; messages go to the terminal only\n", path.c_str());
  } else if (!path.empty()) {
    f.open(path, std::ios::app);
    // Another user's run folder resumed: log.txt kept only the first user's lines, in silence (red team, session
    // 29). Said on the terminal; the run goes on.
    if (!f.is_open() && g_level.load() <= static_cast<int>(LogLevel::Warn))
      std::fprintf(stderr, "[varbo warning] %s: cannot append to the log file (%s); messages go to the terminal only\n",
                   path.c_str(), std::strerror(errno));
  }
}

void log_file_message(LogLevel level, std::string_view message) {
  std::lock_guard<std::mutex> lock(g_mutex);
  auto& f = log_file();
  if (f.is_open()) {
    f << "[" << tag(level) << "] " << hide_url_passwords(message) << '\n';
    f.flush();
  }
}

namespace {
thread_local int t_info_as_debug = 0;
}
InfoAsDebug::InfoAsDebug() { ++t_info_as_debug; }
InfoAsDebug::~InfoAsDebug() { --t_info_as_debug; }

void log_message(LogLevel level, std::string_view message) {
  if (level == LogLevel::Info && t_info_as_debug > 0) level = LogLevel::Debug;
  std::lock_guard<std::mutex> lock(g_mutex);
  write_message(level, message);
}

void log_warn_once(std::string_view message) {
  static std::set<std::string> said;                           // on stderr
  static std::set<std::pair<std::string, std::string>> filed;  // (log file, message)
  std::lock_guard<std::mutex> lock(g_mutex);
  const std::string m(message);
  const bool first = said.insert(m).second;
  const bool to_file = log_file().is_open() && filed.insert({log_file_path(), m}).second;
  if (first) {
    write_message(LogLevel::Warn, message);
  } else if (to_file) {
    log_file() << "[" << tag(LogLevel::Warn) << "] " << message << '\n';
    log_file().flush();
  }
}

}  // namespace varbo
