#pragma once
// Minimal leveled logging to stderr and optionally a run's log file. Thread-safe.
#include <fmt/format.h>
#include <string>
#include <string_view>

namespace varbo {

enum class LogLevel { Debug = 0, Info = 1, Warn = 2, Error = 3, Quiet = 4 };
void set_log_level(LogLevel level);
LogLevel log_level();
/// Also append every message (any level >= Info) to this file; empty closes it.
void set_log_file(const std::string& path);
void log_message(LogLevel level, std::string_view message);
/// To the log file only (when one is open): an error the caller reports on stderr itself, which a run's
/// log.txt must still hold.
void log_file_message(LogLevel level, std::string_view message);
/// A warning about the configuration, said once per process on stderr (a command builds its algorithm more than
/// once: checks, then the run) and once in each log file opened afterwards, so a run's log.txt holds it too.
void log_warn_once(std::string_view message);

/// While one is alive, this thread's info messages are debug ones (shown with -v, not in the log file): a study
/// rebuilt by replaying its trials (each re-asked of the algorithm) repeated every trial's info lines on every
/// `varbo suggest` (red team, session 30). Warnings and errors pass.
class InfoAsDebug {
 public:
  InfoAsDebug();
  ~InfoAsDebug();
  InfoAsDebug(const InfoAsDebug&) = delete;
  InfoAsDebug& operator=(const InfoAsDebug&) = delete;
};

template <class... Args>
void log_debug(fmt::format_string<Args...> f, Args&&... args) {
  if (log_level() <= LogLevel::Debug) log_message(LogLevel::Debug, fmt::format(f, std::forward<Args>(args)...));
}
template <class... Args>
void log_info(fmt::format_string<Args...> f, Args&&... args) {
  log_message(LogLevel::Info, fmt::format(f, std::forward<Args>(args)...));
}
template <class... Args>
void log_warn(fmt::format_string<Args...> f, Args&&... args) {
  log_message(LogLevel::Warn, fmt::format(f, std::forward<Args>(args)...));
}

}  // namespace varbo
