#pragma once
// Cgroup v2 containment of one external command (issue 11 item 2). Each trial gets its own cgroup,
// `varbo-trial-<varbo's pid>-<n>`, below the cgroup varbo runs in; the command's shell enters it between
// fork and exec, so everything the command ever starts is in it, whatever process group, session or
// environment it moves to, and even after its supervisor is killed. Stopping the trial writes `cgroup.kill`
// (Linux >= 5.14; before: freeze, SIGKILL each listed process, thaw, repeated), which kills the lot at once,
// then waits until the cgroup is empty and removes it.
//
// Where this is impossible (cgroup v1 only, no write access to varbo's cgroup — not root and no delegation —,
// a read-only cgroupfs, a container) varbo falls back to the process-group + /proc tree walk + token sweep
// of process_tree.hpp and subprocess.cpp, which also stay on as the second line of defence.
#include <sys/types.h>

#include <string>

namespace varbo::tasks {

/// `containment:` of the external task.
enum class Containment {
  Auto,         ///< a cgroup per trial where the machine allows it, else the process group and tree walk
  Cgroup,       ///< a cgroup per trial, or the trial fails (saying why cgroups cannot be used)
  ProcessGroup  ///< no cgroup: the process group, the supervisor's tree walk and the token sweep only
};

/// The cgroup v2 directory varbo runs in (from /proc/self/cgroup and /proc/self/mountinfo), resolved once per
/// process; empty, with the reason in `why`, where there is none. The first call also removes empty trial
/// cgroups left by varbo processes that no longer exist (a varbo killed by SIGKILL with its supervisors).
struct CgroupHome {
  std::string dir;
  std::string why;
};
const CgroupHome& cgroup_home();

/// Empty when a trial cgroup can be made here (checked once per process by making and removing one), else why
/// not: for `containment: cgroup` to refuse up front.
const std::string& cgroup_unavailable();

/// The prefix of trial cgroup names.
inline constexpr const char* kTrialCgroupPrefix = "varbo-trial-";

/// One trial's cgroup, owned by the calling varbo: removed (after killing what is in it) by remove() or the
/// destructor.
class TrialCgroup {
 public:
  TrialCgroup() = default;
  TrialCgroup(const TrialCgroup&) = delete;
  TrialCgroup& operator=(const TrialCgroup&) = delete;
  ~TrialCgroup() { remove(); }

  /// Makes the cgroup. False, with the reason in `why`, when it cannot (nothing is left behind then).
  bool create(std::string& why);
  bool active() const { return dir_fd_ >= 0; }
  /// Its directory, open (O_RDONLY, O_CLOEXEC), for the async-signal-safe calls below; -1 when inactive.
  int dir_fd() const { return dir_fd_; }
  const std::string& path() const { return path_; }

  /// Kills every process in it and in any cgroup below it (a nested varbo's), waits until it is empty (at
  /// most `max_seconds`) and removes it and the cgroups below. False when something could not be removed.
  bool remove(double max_seconds = 3.0);

 private:
  std::string path_;
  int dir_fd_ = -1;
};

// Async-signal-safe (raw system calls, no allocation): for the supervisor, a forked child of a possibly
// multi-threaded varbo, as well as for varbo itself. `dir_fd` is a TrialCgroup's dir_fd().
namespace cgroup_raw {
/// Moves the calling process into the cgroup; 0 or the errno of the failure.
int enter(int dir_fd);
/// True while a process is in the cgroup or below it (cgroup.events "populated 1").
bool populated(int dir_fd);
/// Sends `sig` (then SIGCONT when sig is SIGTERM) to every process listed in cgroup.procs; how many.
int signal_listed(int dir_fd, int sig);
/// SIGKILL to every process in the cgroup and below: cgroup.kill, or freeze + signal_listed + thaw.
void kill_all(int dir_fd);
}  // namespace cgroup_raw

}  // namespace varbo::tasks
