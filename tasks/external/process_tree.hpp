#pragma once
// The supervisor: a small process between varbo and an external command that owns everything the command
// starts. It is a child subreaper (prctl PR_SET_CHILD_SUBREAPER), so every orphan of the command re-parents
// to it, even one that left the command's process group or session (`setsid sleep 20 &`); it can therefore
// find the whole tree (its descendants, from /proc) and kill it, which killing a process group cannot do.
// It also watches varbo: when varbo dies, even by SIGKILL, the kernel sends it SIGTERM (PR_SET_PDEATHSIG)
// and it takes the command's tree down with it.
//
// Protocol on the report pipe: {kPid, pid of the shell} once it is forked, {kStatus, its wait status} when it
// has exited, {kStartError, errno} if fork failed, {kCgroupError, errno} (from the shell's process, before
// its exec) if it could not enter the trial's cgroup. The supervisor then kills what the command left and exits.
// Sending it SIGTERM (or SIGINT/SIGHUP) stops the command: SIGTERM to the tree, then SIGKILL after the grace.
#include <sys/types.h>

namespace varbo::tasks {

struct SupervisorPlan {
  const char* const* argv = nullptr;  ///< the command, e.g. {"sh", "-c", text, nullptr}
  const char* path = "/bin/sh";
  const char* workdir = nullptr;      ///< nullptr: inherit
  char* const* envp = nullptr;        ///< the command's environment; nullptr: varbo's
  int stdin_fd = -1, stdout_fd = -1, stderr_fd = -1;  ///< the command's ends of the pipes
  /// varbo's (read) ends of the command's stdout and stderr pipes, held by the supervisor so that they outlive
  /// varbo: once varbo is gone the supervisor drains them, and a command that writes while it brings the hardware
  /// to a safe state (its grace) is not killed by SIGPIPE (audit, session 45: "motors off" on stderr ended the
  /// shell's SIGTERM trap). -1: none.
  int stdout_read_fd = -1, stderr_read_fd = -1;
  int report_fd = -1;                  ///< write end of the report pipe (O_CLOEXEC)
  pid_t parent = 0;                    ///< varbo's pid
  long grace_ms = 200;                 ///< SIGTERM -> SIGKILL delay when told to stop
  /// The supervisor's own deadline, in ms from its start (-1: none): it stops the command then, as when told to.
  /// varbo enforces the trial's timeout itself; this is the backstop for a varbo that cannot (stopped by Ctrl-Z or
  /// by the command: `kill -STOP $PPID`'s parent ran on past its timeout; red team, session 34).
  long deadline_ms = -1;
  /// The trial's cgroup (trial_cgroup.hpp), open directory, or -1: the shell enters it before exec, and the
  /// supervisor kills through it (cgroup.kill) before its tree walk, then removes it.
  int cgroup_fd = -1;
  const char* cgroup_path = nullptr;
  bool cgroup_required = false;        ///< the shell exits 126 (saying why) if it cannot enter the cgroup
  /// varbo's run locks (held_locks.hpp), kept open by the supervisor until the command's tree is gone: a varbo
  /// killed by SIGKILL keeps its run lock while its last trial's command is being stopped.
  int lock_fds[3] = {-1, -1, -1};
};

enum SupervisorReport : int { kPid = 1, kStatus = 2, kStartError = 3, kCgroupError = 4 };

/// Runs in the child of fork() and never returns. Makes only async-signal-safe calls (the parent may have
/// other threads), so everything it needs is prepared in `plan` before the fork.
[[noreturn]] void run_supervisor(const SupervisorPlan& plan);

}  // namespace varbo::tasks
