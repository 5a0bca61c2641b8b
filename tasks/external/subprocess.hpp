#pragma once
// Runs a shell command with a time limit, feeding it stdin and collecting stdout/stderr, without ever
// hanging or leaving a process behind. The command runs under a supervisor process (process_tree.hpp)
// that finds and kills its whole tree — background jobs, processes in a new session, orphans — when the
// command exits, when the deadline passes, when varbo is asked to stop (interrupt.hpp) and when varbo
// dies. Where the machine allows it, the command also runs in a cgroup of its own (trial_cgroup.hpp), which
// holds every process it starts whatever it does, and is killed as a whole. Non-blocking pipes multiplexed with poll(); SIGPIPE blocked in the calling thread while writing
// stdin; at most max_stdout bytes of output are held in memory.
#include <cstddef>
#include <string>
#include <vector>

#include "trial_cgroup.hpp"

namespace varbo::tasks {

struct ProcessOptions {
  double timeout_seconds = 600;
  std::string working_directory;             ///< empty: inherit
  std::size_t max_stdout = 1u << 20;         ///< beyond this only the tail is kept (the answer is at the end)
  std::size_t max_stderr = 64u << 10;        ///< tail kept
  double kill_grace_seconds = 0.2;           ///< SIGTERM -> SIGKILL delay when the command is stopped
  /// After the command has exited, how long its output may stay open: a process outside its tree (which
  /// the supervisor cannot find) may hold it; reading stops then.
  double output_close_seconds = 2.0;
  /// How the command's processes are held together (trial_cgroup.hpp): a cgroup per trial where possible
  /// (Auto), always (Cgroup: the trial does not start without one), or never (ProcessGroup).
  Containment containment = Containment::Auto;
  /// NAME=value entries added to the command's environment (replacing inherited ones of those names).
  std::vector<std::string> environment;
  /// The shell's positional parameters $1, $2, … (`sh -c COMMAND varbo-trial ARG…`; args_placement.hpp).
  std::vector<std::string> arguments;
};

struct ProcessResult {
  bool started = false;     ///< false: pipe/fork failed, see `error`
  bool timed_out = false;   ///< still running at the deadline: its tree was killed
  int interrupted = 0;      ///< the stop signal varbo received while the command ran (its tree was killed)
  bool output_held = false; ///< it exited, but its stdout/stderr stayed open; reading stopped
  bool exited = false;      ///< exited normally (then exit_status is valid)
  int exit_status = -1;
  int signal = 0;           ///< terminating signal when !exited
  std::string out;          ///< stdout (its last max_stdout bytes)
  std::size_t out_dropped = 0;  ///< bytes of stdout read but not kept (from the front)
  std::string err;          ///< stderr tail
  std::string error;        ///< why it could not start
  double seconds = 0;       ///< wall time
  bool in_cgroup = false;   ///< the command ran in a trial cgroup of its own (trial_cgroup.hpp)
  /// "exit status 3", "killed by signal 9 (Killed)", "timed out after 0.5 s", ...
  std::string status_text() const;
};

/// Runs `/bin/sh -c command` with `input` on stdin. Never throws for a failing command. Safe to call from
/// several threads at once.
ProcessResult run_shell(const std::string& command, const std::string& input, const ProcessOptions& options);

}  // namespace varbo::tasks
