#include "process_tree.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <initializer_list>

#include "signal_safe_text.hpp"
#include "trial_cgroup.hpp"

extern char** environ;

// Everything below runs in a forked child of a possibly multi-threaded process: no allocation, no stdio,
// no locks — raw system calls and fixed buffers only (static storage is private to the child after fork).

namespace varbo::tasks {

namespace {

constexpr int kMaxTracked = 8192;  // descendants handled per sweep; more are caught by the next sweep
pid_t g_tree[kMaxTracked];
int g_tree_size = 0;

long now_ms() {
  timespec ts;
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec * 1000L + ts.tv_nsec / 1000000L;
}

void sleep_ms(long ms) {
  timespec ts{ms / 1000, (ms % 1000) * 1000000L};
  while (::nanosleep(&ts, &ts) != 0 && errno == EINTR) {
  }
}

void report(int fd, int kind, int value) {
  const int msg[2] = {kind, value};
  ssize_t w;
  do {
    w = ::write(fd, msg, sizeof msg);
  } while (w < 0 && errno == EINTR);
}

bool parse_pid(const char* s, pid_t& out) {
  if (*s == '\0') return false;
  long v = 0;
  for (; *s; ++s) {
    if (*s < '0' || *s > '9') return false;
    v = v * 10 + (*s - '0');
    if (v > 0x3fffffff) return false;
  }
  out = static_cast<pid_t>(v);
  return true;
}

// The parent pid from /proc/PID/stat ("pid (comm) state ppid ..."; comm may hold spaces and ')').
pid_t parent_of(pid_t pid) {
  char path[40] = "/proc/";
  int len = 6 + signal_safe::decimal(pid, path + 6);
  for (const char* t = "/stat"; *t;) path[len++] = *t++;
  path[len] = '\0';
  const int fd = ::open(path, O_RDONLY | O_CLOEXEC);
  if (fd < 0) return -1;
  char buf[1024];
  const ssize_t got = ::read(fd, buf, sizeof buf - 1);
  ::close(fd);
  if (got <= 0) return -1;
  buf[got] = '\0';
  const char* close_paren = nullptr;
  for (const char* c = buf; *c; ++c)
    if (*c == ')') close_paren = c;
  if (close_paren == nullptr || close_paren[1] != ' ' || close_paren[2] == '\0' || close_paren[3] != ' ')
    return -1;
  long ppid = 0;
  for (const char* c = close_paren + 4; *c >= '0' && *c <= '9'; ++c) ppid = ppid * 10 + (*c - '0');
  return static_cast<pid_t>(ppid);
}

bool tracked(pid_t pid) {
  for (int i = 0; i < g_tree_size; ++i)
    if (g_tree[i] == pid) return true;
  return false;
}

// Fills g_tree with the descendants of this process (false: /proc cannot be read): every process whose parent is this process or a
// process already found. Orphans re-parent to us (subreaper), so the parent chains never leave the tree.
// Repeated passes catch children listed in /proc before their parent.
bool find_descendants() {
  g_tree_size = 0;
  const pid_t self = ::getpid();
  const int dir = ::open("/proc", O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir < 0) return false;
  alignas(8) char buf[16384];
  for (int pass = 0; pass < 16; ++pass) {
    bool grew = false;
    ::lseek(dir, 0, SEEK_SET);
    for (;;) {
      const long got = ::syscall(SYS_getdents64, dir, buf, sizeof buf);
      if (got <= 0) break;
      for (long off = 0; off < got;) {
        // struct linux_dirent64 { u64 ino; s64 off; u16 reclen; u8 type; char name[]; }
        unsigned short reclen;
        std::memcpy(&reclen, buf + off + 16, sizeof reclen);
        const char* name = buf + off + 19;
        off += reclen;
        pid_t pid;
        if (!parse_pid(name, pid) || pid == self || tracked(pid)) continue;
        const pid_t ppid = parent_of(pid);
        if (ppid <= 0 || (ppid != self && !tracked(ppid))) continue;
        if (g_tree_size < kMaxTracked) {
          g_tree[g_tree_size++] = pid;
          grew = true;
        }
      }
    }
    if (!grew) break;
  }
  ::close(dir);
  return true;
}

// Collects every exited child (orphans of the command included), noting the shell's status.
void reap(pid_t shell, int& shell_status, bool& shell_done) {
  for (;;) {
    int st = 0;
    const pid_t w = ::waitpid(-1, &st, WNOHANG);
    if (w <= 0) return;
    if (w == shell) {
      shell_status = st;
      shell_done = true;
    }
  }
}

// Sends `sig` to every descendant; returns how many there were. Without /proc, falls back to the shell's
// process group (what stayed in it).
int signal_tree(int sig, pid_t shell) {
  if (!find_descendants()) {
    if (shell > 0) ::kill(-shell, sig);
    return 0;
  }
  for (int i = 0; i < g_tree_size; ++i) {
    ::kill(g_tree[i], sig);
    if (sig == SIGTERM) ::kill(g_tree[i], SIGCONT);  // a stopped process must run to see SIGTERM
  }
  return g_tree_size;
}

// Reads and discards what the command wrote to varbo's ends of its pipes, without blocking (poll first: the ends
// are shared with varbo's, whose flags are not ours to change). Only once varbo is gone: then nobody else reads
// them, and a command whose pipe has no reader dies of SIGPIPE at its next write, a full one blocks.
void drain(int out_fd, int err_fd) {
  char sink[4096];
  for (const int fd : {out_fd, err_fd}) {
    if (fd < 0) continue;
    for (int round = 0; round < 64; ++round) {
      pollfd pfd{fd, POLLIN, 0};
      if (::poll(&pfd, 1, 0) <= 0 || (pfd.revents & POLLIN) == 0) break;
      if (::read(fd, sink, sizeof sink) <= 0) break;
    }
  }
}

// strerror is not async-signal-safe: the reasons a chdir or an execve of /bin/sh plausibly fail with.
const char* errno_text(int e) {
  switch (e) {
    case ENOENT: return "No such file or directory";
    case ENOTDIR: return "Not a directory";
    case EACCES: return "Permission denied";
    case ELOOP: return "Too many levels of symbolic links";
    case ENAMETOOLONG: return "File name too long";
    case E2BIG: return "Argument list too long (the kernel takes at most 128 KiB in one argument and ~2 MiB in "
                       "all: a long command belongs in a script, and θ with thousands of values on stdin, "
                       "`input: json`, not `input: args`)";
    case ENOMEM: return "Cannot allocate memory";
    case ENOEXEC: return "Exec format error";
    case ETXTBSY: return "Text file busy";
    case EIO: return "Input/output error";
    case EPERM: return "Operation not permitted";
    case EROFS: return "Read-only file system";
    case EBUSY: return "Device or resource busy";
    case EINVAL: return "Invalid argument";
    case EOPNOTSUPP: return "Operation not supported";
    default: return "system error";
  }
}

void write_all(int fd, const char* text) {
  std::size_t n = 0;
  while (text[n] != '\0') ++n;
  while (n > 0) {
    const ssize_t w = ::write(fd, text, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return;
    text += w;
    n -= static_cast<std::size_t>(w);
  }
}

// "varbo external task: <what><path><sep><reason>\n" on stderr, from the forked child (async-signal-safe).
void write_failure(const char* what, const char* path, const char* sep, const char* reason) {
  for (const char* part : {"varbo external task: ", what, path, sep, reason, "\n"}) write_all(STDERR_FILENO, part);
}

void close_all_but(const int* keep, int n) {
  // Closes [0, max) except the kept descriptors, with close_range between them.
  int sorted[12];
  for (int i = 0; i < n; ++i) sorted[i] = keep[i];
  for (int i = 1; i < n; ++i)
    for (int j = i; j > 0 && sorted[j - 1] > sorted[j]; --j) {
      const int t = sorted[j];
      sorted[j] = sorted[j - 1];
      sorted[j - 1] = t;
    }
  unsigned lo = 0;
  for (int i = 0; i <= n; ++i) {
    const unsigned hi = i < n ? static_cast<unsigned>(sorted[i]) : ~0u;
    if (hi > lo) {
      if (::syscall(SYS_close_range, lo, hi - 1, 0) != 0) {
        rlimit rl;
        const unsigned limit =
            ::getrlimit(RLIMIT_NOFILE, &rl) == 0 && rl.rlim_cur < 1048576 ? static_cast<unsigned>(rl.rlim_cur) : 65536u;
        for (unsigned fd = lo; fd < hi && fd < limit; ++fd) ::close(static_cast<int>(fd));
      }
    }
    if (i < n) lo = static_cast<unsigned>(sorted[i]) + 1;
  }
}

[[noreturn]] void exec_command(const SupervisorPlan& p) {
  // Into the trial's cgroup first, before anything of the command runs: all it ever starts inherits it.
  if (p.cgroup_fd >= 0) {
    if (const int e = cgroup_raw::enter(p.cgroup_fd)) {
      if (p.cgroup_required) {
        write_failure("containment: cgroup: cannot enter the trial's cgroup ", p.cgroup_path, ": ", errno_text(e));
        ::_exit(126);
      }
      report(p.report_fd, kCgroupError, e);  // varbo falls back to the process group and tree walk
    }
  }
  ::setpgid(0, 0);  // its own group: a terminal's Ctrl-C goes to varbo, which stops the command itself
  // Onto 0, 1, 2 via high copies, so that no dup2 overwrites a descriptor still to be copied.
  const int in = ::fcntl(p.stdin_fd, F_DUPFD_CLOEXEC, 10);
  const int out = ::fcntl(p.stdout_fd, F_DUPFD_CLOEXEC, 10);
  const int err = ::fcntl(p.stderr_fd, F_DUPFD_CLOEXEC, 10);
  if (in < 0 || out < 0 || err < 0) ::_exit(126);
  ::dup2(in, STDIN_FILENO);
  ::dup2(out, STDOUT_FILENO);
  ::dup2(err, STDERR_FILENO);
  struct sigaction dfl;
  std::memset(&dfl, 0, sizeof dfl);
  dfl.sa_handler = SIG_DFL;
  for (int s : {SIGPIPE, SIGXFSZ, SIGINT, SIGTERM, SIGHUP, SIGQUIT, SIGCHLD}) ::sigaction(s, &dfl, nullptr);
  sigset_t none;
  sigemptyset(&none);
  ::sigprocmask(SIG_SETMASK, &none, nullptr);
  if (p.workdir != nullptr && ::chdir(p.workdir) != 0) {
    // Named, with the reason: the message is what trials.csv shows for every trial of such a run.
    write_failure("cannot change to the working directory '", p.workdir, "': ", errno_text(errno));
    ::_exit(126);
  }
  ::execve(p.path, const_cast<char* const*>(p.argv), p.envp != nullptr ? p.envp : environ);
  // Said, not only exit 127 ("command not found?"): a 3 MB command line fails here with E2BIG.
  write_failure("cannot run ", p.path, ": ", errno_text(errno));
  ::_exit(127);
}

}  // namespace

[[noreturn]] void run_supervisor(const SupervisorPlan& p) {
  // Signals are taken synchronously (sigtimedwait), none asynchronously.
  sigset_t all;
  sigfillset(&all);
  ::sigprocmask(SIG_SETMASK, &all, nullptr);
  struct sigaction dfl;
  std::memset(&dfl, 0, sizeof dfl);
  dfl.sa_handler = SIG_DFL;
  ::sigaction(SIGCHLD, &dfl, nullptr);  // not SIG_IGN, which would reap for us and hide the shell's status
  ::setpgid(0, 0);  // out of varbo's group too
  ::prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0);
  ::prctl(PR_SET_PDEATHSIG, SIGTERM, 0, 0, 0);
  bool stop = ::getppid() != p.parent;  // varbo died before PDEATHSIG was armed
  {
    // Only our four pipe ends stay open: varbo's other descriptors (another trial's pipes, in a
    // multi-threaded varbo) must not be held by us or the command.
    int keep[12] = {p.stdin_fd, p.stdout_fd, p.stderr_fd, p.report_fd};
    int n = 4;
    for (const int fd : {p.stdout_read_fd, p.stderr_read_fd})
      if (fd >= 0) keep[n++] = fd;
    if (p.cgroup_fd >= 0) keep[n++] = p.cgroup_fd;
    for (const int fd : p.lock_fds)
      if (fd >= 0) keep[n++] = fd;
    close_all_but(keep, n);
  }
  const pid_t shell = stop ? -1 : ::fork();
  if (shell == 0) exec_command(p);
  if (shell < 0 && !stop) report(p.report_fd, kStartError, errno);
  if (shell > 0) {
    ::setpgid(shell, shell);  // also from here: no race with a kill before the child's own setpgid
    report(p.report_fd, kPid, shell);
  }
  // We must not hold the command's pipes: its output ends when the command's tree is gone.
  ::close(p.stdin_fd);
  ::close(p.stdout_fd);
  ::close(p.stderr_fd);

  sigset_t wake;
  sigemptyset(&wake);
  for (int s : {SIGCHLD, SIGTERM, SIGINT, SIGHUP, SIGQUIT}) sigaddset(&wake, s);
  int shell_status = 0;
  bool shell_done = shell <= 0;
  const long deadline = p.deadline_ms >= 0 ? now_ms() + p.deadline_ms : -1;
  while (!shell_done && !stop) {
    const timespec tick{0, 100 * 1000000L};
    const int s = ::sigtimedwait(&wake, nullptr, &tick);
    if (s == SIGTERM || s == SIGINT || s == SIGHUP || s == SIGQUIT) stop = true;
    reap(shell, shell_status, shell_done);
    if (::getppid() != p.parent) stop = true;
    if (deadline >= 0 && now_ms() >= deadline) stop = true;
  }
  const bool reported = shell_done && shell > 0;
  if (reported) report(p.report_fd, kStatus, shell_status);  // the verdict first: varbo may be waiting

  // With a cgroup that holds the command (it is empty only if the shell could not enter it, or if everything
  // has already ended), every process of the command is listed there, wherever it moved: a new session, a
  // cleared environment, an orphan of a killed supervisor of a nested varbo.
  const bool in_cgroup = p.cgroup_fd >= 0 && cgroup_raw::populated(p.cgroup_fd);
  if (stop) {
    // Polite first (a simulator may want to save its state), then certain.
    const long hard = now_ms() + p.grace_ms;
    // The cgroup lists every process of the command: no walk of /proc (which reads every process's stat, a
    // few times over) is needed for the polite round; the SIGKILL round below still walks the tree once.
    if (in_cgroup) cgroup_raw::signal_listed(p.cgroup_fd, SIGTERM);
    else signal_tree(SIGTERM, shell);
    while (now_ms() < hard) {
      if (::getppid() != p.parent) drain(p.stdout_read_fd, p.stderr_read_fd);
      reap(shell, shell_status, shell_done);
      if (in_cgroup ? !cgroup_raw::populated(p.cgroup_fd) : (!find_descendants() || g_tree_size == 0)) break;
      sleep_ms(5);
    }
  }
  // Whatever is left (background jobs, daemons in their own session) would outlive the trial and could hold
  // its pipes: kill it — the cgroup at once, then sweeps of the tree for anything outside it (or everything,
  // without a cgroup) and for what it forked meanwhile —, reap, until nothing is left (bounded).
  const long give_up = now_ms() + 3000;
  if (in_cgroup) {
    while (cgroup_raw::populated(p.cgroup_fd) && now_ms() < give_up) {
      cgroup_raw::kill_all(p.cgroup_fd);
      reap(shell, shell_status, shell_done);
      if (!cgroup_raw::populated(p.cgroup_fd)) break;
      sleep_ms(1);
    }
  }
  while (signal_tree(SIGKILL, shell) > 0 && now_ms() < give_up) {
    if (::getppid() != p.parent) drain(p.stdout_read_fd, p.stderr_read_fd);
    sleep_ms(2);
    reap(shell, shell_status, shell_done);
  }
  // Empty now: removed here too, so that a varbo killed by SIGKILL leaves none behind (varbo removes it
  // otherwise; a nested varbo's cgroups below it make this rmdir fail, and varbo removes those first).
  if (p.cgroup_path != nullptr && p.cgroup_fd >= 0 && !cgroup_raw::populated(p.cgroup_fd)) ::rmdir(p.cgroup_path);
  reap(shell, shell_status, shell_done);
  if (!reported && shell_done && shell > 0) report(p.report_fd, kStatus, shell_status);
  ::_exit(0);
}

}  // namespace varbo::tasks
