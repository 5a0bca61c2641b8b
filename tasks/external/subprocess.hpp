#pragma once
// Runs a shell command with a time limit, feeding it stdin and collecting stdout/stderr, without ever
// hanging or leaving zombies: fork/execve of /bin/sh -c in its own process group, non-blocking pipes
// multiplexed with poll(), the whole group killed on timeout (and any background stragglers killed
// once the shell exits), SIGPIPE blocked in the calling thread while writing stdin.
#include <cstddef>
#include <string>

namespace varbo::tasks {

struct ProcessOptions {
  double timeout_seconds = 600;
  std::string working_directory;             ///< empty: inherit
  std::size_t max_stdout = 16u << 20;        ///< beyond this only the tail is kept
  std::size_t max_stderr = 64u << 10;        ///< tail kept
  double kill_grace_seconds = 0.2;           ///< SIGTERM -> SIGKILL delay on timeout
};

struct ProcessResult {
  bool started = false;     ///< false: pipe/fork failed, see `error`
  bool timed_out = false;
  bool exited = false;      ///< exited normally (then exit_status is valid)
  int exit_status = -1;
  int signal = 0;           ///< terminating signal when !exited
  std::string out;          ///< stdout (tail if longer than max_stdout)
  std::string err;          ///< stderr tail
  std::string error;        ///< why it could not start
  double seconds = 0;       ///< wall time
  /// "exit status 3", "killed by signal 9 (Killed)", "timed out after 0.5 s", ...
  std::string status_text() const;
};

/// Runs `/bin/sh -c command` with `input` on stdin. Never throws for a failing command.
ProcessResult run_shell(const std::string& command, const std::string& input, const ProcessOptions& options);

}  // namespace varbo::tasks
