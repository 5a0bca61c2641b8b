#include "subprocess.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <dirent.h>

#include <algorithm>
#include <atomic>
#include <string_view>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <iterator>
#include <random>
#include <thread>
#include <vector>

#include "process_tree.hpp"
#include "varbo/held_locks.hpp"
#include "varbo/interrupt.hpp"
#include "varbo/log.hpp"

extern char** environ;

namespace varbo::tasks {

namespace {

using Clock = std::chrono::steady_clock;

struct Fd {
  int fd = -1;
  Fd() = default;
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  ~Fd() { close(); }
  void close() {
    if (fd >= 0) ::close(fd);
    fd = -1;
  }
  bool open() const { return fd >= 0; }
};

bool make_pipe(Fd& read_end, Fd& write_end) {
  int p[2];
  if (::pipe2(p, O_CLOEXEC) != 0) return false;
  read_end.fd = p[0];
  write_end.fd = p[1];
  return true;
}

void set_nonblocking(int fd) { ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) | O_NONBLOCK); }

// The last `cap` bytes of a stream, in amortized linear time: the buffer grows to 2·cap before its front
// is dropped (a 50 MB line costs one pass, not one copy of the buffer per read).
struct Tail {
  std::string& text;
  std::size_t& dropped;
  std::size_t cap;
  void append(const char* data, std::size_t n) {
    text.append(data, n);
    if (text.size() > 2 * cap) trim();
  }
  void trim() {
    if (text.size() <= cap) return;
    dropped += text.size() - cap;
    text.erase(0, text.size() - cap);
  }
};

// Reads what is available; returns false on EOF or a hard error (the fd is then closed).
bool drain(Fd& fd, Tail& sink) {
  char buf[65536];
  for (;;) {
    const ssize_t n = ::read(fd.fd, buf, sizeof buf);
    if (n > 0) {
      sink.append(buf, static_cast<std::size_t>(n));
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return true;
    fd.close();
    return false;
  }
}

// Writes to a pipe whose reader may be gone. SIGPIPE is blocked in this thread for the write, and a
// SIGPIPE raised by it is consumed (unless one was already pending), so only EPIPE is seen.
ssize_t write_no_sigpipe(int fd, const char* data, std::size_t n) {
  sigset_t pipe_set, old_mask, pending;
  sigemptyset(&pipe_set);
  sigaddset(&pipe_set, SIGPIPE);
  sigpending(&pending);
  const bool was_pending = sigismember(&pending, SIGPIPE) == 1;
  pthread_sigmask(SIG_BLOCK, &pipe_set, &old_mask);
  ssize_t w;
  do {
    w = ::write(fd, data, n);
  } while (w < 0 && errno == EINTR);
  const int saved = errno;
  if (w < 0 && saved == EPIPE && !was_pending) {
    const timespec zero{0, 0};
    while (sigtimedwait(&pipe_set, nullptr, &zero) < 0 && errno == EINTR) {
    }
  }
  pthread_sigmask(SIG_SETMASK, &old_mask, nullptr);
  errno = saved;
  return w;
}

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

Clock::duration seconds(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

int ms_until(Clock::time_point t, Clock::time_point now) {
  return static_cast<int>(
      std::clamp<long long>(std::chrono::duration_cast<std::chrono::milliseconds>(t - now).count() + 1, 0, 50));
}

// What the supervisor tells us (process_tree.hpp): the shell's pid, then its wait status.
struct Reports {
  Fd fd;
  pid_t shell = -1;
  bool have_status = false;
  int status = 0;
  int start_errno = 0;
  int cgroup_errno = 0;  ///< the shell could not enter the trial's cgroup
  bool eof = false;
  std::string partial;
  void read() {
    char buf[64];
    for (;;) {
      const ssize_t n = ::read(fd.fd, buf, sizeof buf);
      if (n > 0) {
        partial.append(buf, static_cast<std::size_t>(n));
        continue;
      }
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) break;
      eof = true;
      fd.close();
      break;
    }
    while (partial.size() >= 2 * sizeof(int)) {
      int msg[2];
      std::memcpy(msg, partial.data(), sizeof msg);
      partial.erase(0, sizeof msg);
      if (msg[0] == kPid) shell = msg[1];
      if (msg[0] == kStatus) {
        have_status = true;
        status = msg[1];
      }
      if (msg[0] == kStartError) start_errno = msg[1];
      if (msg[0] == kCgroupError) cgroup_errno = msg[1];
    }
  }
  bool command_ended() const { return have_status || eof || start_errno != 0; }
};

// The environment variable that marks every process of one command (process_tree.hpp cannot find a
// command's processes once its supervisor is gone: they re-parent to init). Unique per call and process.
constexpr const char* kTokenVar = "VARBO_TRIAL_TOKEN";

std::string new_token() {
  static std::atomic<unsigned long> counter{0};
  static const unsigned long salt = std::random_device{}();
  return fmt::format("{}.{}.{:x}", static_cast<long>(::getpid()), counter.fetch_add(1), salt);
}

// Sends `sig` to every process whose environment holds `entry` (VARBO_TRIAL_TOKEN=...); returns how many.
// The fallback for a supervisor that was killed (SIGKILL from the command itself, `kill -9 $PPID`): the
// command's tree is then orphaned, out of reach of any process-tree walk. A process that cleared its
// environment (env -i) escapes this sweep; it is still in the shell's process group unless it left it.
int signal_token(const std::string& entry, int sig) {
  DIR* d = ::opendir("/proc");
  if (d == nullptr) return 0;
  int n = 0;
  const pid_t self = ::getpid();
  while (const dirent* e = ::readdir(d)) {
    char* end = nullptr;
    const long pid = std::strtol(e->d_name, &end, 10);
    if (pid <= 0 || *end != '\0' || pid == self) continue;
    std::ifstream env(fmt::format("/proc/{}/environ", pid), std::ios::binary);
    if (!env) continue;
    const std::string text((std::istreambuf_iterator<char>(env)), std::istreambuf_iterator<char>());
    bool found = false;
    for (std::size_t at = 0; at < text.size() && !found;) {
      const std::size_t z = text.find('\0', at);
      const std::size_t len = (z == std::string::npos ? text.size() : z) - at;
      found = len == entry.size() && text.compare(at, len, entry) == 0;
      at += len + 1;
    }
    if (found && ::kill(static_cast<pid_t>(pid), sig) == 0) ++n;
  }
  ::closedir(d);
  return n;
}

// The environment of the command: varbo's, plus the token.
struct Environment {
  std::vector<std::string> strings;
  std::vector<char*> pointers;
  Environment(const std::string& token_entry, const std::vector<std::string>& extra) {
    std::vector<std::string> replaced = {kTokenVar};  // a token inherited from an enclosing varbo is replaced
    for (const auto& x : extra) replaced.push_back(x.substr(0, x.find('=')));
    for (char** e = environ; e != nullptr && *e != nullptr; ++e) {
      const std::string_view entry(*e);
      const std::string_view name = entry.substr(0, entry.find('='));
      if (std::find(replaced.begin(), replaced.end(), name) == replaced.end()) strings.emplace_back(*e);
    }
    strings.insert(strings.end(), extra.begin(), extra.end());
    strings.push_back(token_entry);
    for (auto& s : strings) pointers.push_back(s.data());
    pointers.push_back(nullptr);
  }
};

// Once per process: which containment the trials get, and why not a cgroup (a debug line, not a warning:
// most machines without root or delegation cannot, and the fallback is the documented mechanism).
void note_containment(const std::string& why_not) {
  static std::atomic<bool> said{false};
  if (said.exchange(true)) return;
  if (why_not.empty())
    log_debug("external task: each trial runs in its own cgroup v2 below {}", cgroup_home().dir);
  else
    log_debug("external task: trials are contained by their process group and supervisor, not by a cgroup: {}",
              why_not);
}

}  // namespace

std::string ProcessResult::status_text() const {
  if (interrupted && !started) return error;  // "not started: varbo received SIGTERM"
  if (!started) return "could not start: " + error;
  if (interrupted)
    return fmt::format("interrupted by {} after {:.1f} s (the command's process tree was killed)",
                       signal_name(interrupted), seconds);
  if (timed_out) return fmt::format("timed out after {:.1f} s (the command's process tree was killed)", seconds);
  std::string s = exited ? fmt::format("exit status {}", exit_status)
                  : signal ? fmt::format("killed by signal {} ({})", signal, ::strsignal(signal))
                           : std::string("lost (its supervisor process was killed)");
  if (output_held)
    s += fmt::format(", but its output was still open {:.3g} s later (held by a process outside its process "
                     "tree); reading stopped",
                     seconds);
  return s;
}

ProcessResult run_shell(const std::string& command, const std::string& input, const ProcessOptions& options) {
  ProcessResult r;
  const auto t0 = Clock::now();
  if (const int sig = interrupt_signal()) {  // varbo is stopping: start nothing
    r.interrupted = sig;
    r.error = fmt::format("not started: varbo received {}", signal_name(sig));
    return r;
  }
  Fd in_r, in_w, out_r, out_w, err_r, err_w, report_w;
  Reports rep;
  if (!make_pipe(in_r, in_w) || !make_pipe(out_r, out_w) || !make_pipe(err_r, err_w) ||
      !make_pipe(rep.fd, report_w)) {
    r.error = fmt::format("pipe: {}", std::strerror(errno));
    return r;
  }
  // Everything the supervisor needs is prepared before fork: after fork only async-signal-safe calls.
  std::vector<const char*> argv{"sh", "-c", command.c_str()};
  if (!options.arguments.empty()) {
    argv.push_back("varbo-trial");  // $0
    for (const auto& a : options.arguments) argv.push_back(a.c_str());
  }
  argv.push_back(nullptr);
  SupervisorPlan plan;
  plan.argv = argv.data();
  plan.workdir = options.working_directory.empty() ? nullptr : options.working_directory.c_str();
  plan.stdin_fd = in_r.fd;
  plan.stdout_fd = out_w.fd;
  plan.stderr_fd = err_w.fd;
  plan.stdout_read_fd = out_r.fd;
  plan.stderr_read_fd = err_r.fd;
  plan.report_fd = report_w.fd;
  plan.parent = ::getpid();
  plan.grace_ms = static_cast<long>(std::max(0.0, options.kill_grace_seconds) * 1000);
  // The backstop half a second after varbo's own deadline (1e9 s: no limit in practice, as below).
  plan.deadline_ms = static_cast<long>(std::min(options.timeout_seconds, 1e9) * 1000) + 500;
  {
    const std::vector<int> locks = locks_held_for_trials();
    for (std::size_t i = 0; i < locks.size() && i < 3; ++i) plan.lock_fds[i] = locks[i];
  }
  const std::string token_entry = fmt::format("{}={}", kTokenVar, new_token());
  Environment env(token_entry, options.environment);
  plan.envp = env.pointers.data();
  // The trial's cgroup (trial_cgroup.hpp). Failing to make one falls back to the process group and the tree
  // walk, unless `containment: cgroup` asked for it.
  TrialCgroup cgroup;
  if (options.containment != Containment::ProcessGroup) {
    std::string why;
    if (cgroup.create(why)) {
      note_containment("");
    } else if (options.containment == Containment::Cgroup) {
      r.error = "containment: cgroup: " + why;
      return r;
    } else {
      note_containment(why);
    }
  }
  plan.cgroup_fd = cgroup.dir_fd();
  plan.cgroup_path = cgroup.active() ? cgroup.path().c_str() : nullptr;
  plan.cgroup_required = options.containment == Containment::Cgroup;

  // The supervisor must start with every signal blocked (it takes them synchronously): a SIGTERM for a short
  // timeout, or a second Ctrl-C, that arrived between fork() and its own sigprocmask ran varbo's inherited handler
  // in the child and was lost, so only the SIGKILL fallback (grace + 4 s) ended the trial (session 20). The
  // forking thread's mask is what the child inherits; this thread's signals wait the few µs until it is restored.
  sigset_t block_all, previous;
  sigfillset(&block_all);
  ::pthread_sigmask(SIG_SETMASK, &block_all, &previous);
  const pid_t supervisor = ::fork();
  const int fork_errno = errno;
  if (supervisor == 0) run_supervisor(plan);
  ::pthread_sigmask(SIG_SETMASK, &previous, nullptr);
  if (supervisor < 0) {
    r.error = fmt::format("fork: {}", std::strerror(fork_errno));
    return r;
  }
  r.started = true;
  in_r.close();
  out_w.close();
  err_w.close();
  report_w.close();
  set_nonblocking(in_w.fd);
  set_nonblocking(out_r.fd);
  set_nonblocking(err_r.fd);
  set_nonblocking(rep.fd.fd);
  Tail out{r.out, r.out_dropped, std::max<std::size_t>(options.max_stdout, 1)};
  std::size_t err_dropped = 0;
  Tail err{r.err, err_dropped, std::max<std::size_t>(options.max_stderr, 1)};

  std::size_t written = 0;
  if (input.empty()) in_w.close();
  // Clamped: steady_clock counts nanoseconds in 64 bits, so t0 + 1e300 s overflowed into the past and a
  // `timeout: 1e300` timed every trial out at once. 1e9 s (31 years) is no limit in practice.
  const auto deadline = t0 + seconds(std::min(options.timeout_seconds, 1e9));
  Clock::time_point ended_at{};  // when the command (the shell) ended
  const int stop_fd = interrupt_fd();

  // Until the command has ended and its output is closed. Every wait is bounded: by the deadline while the
  // command runs, by output_close_seconds after it ended, and by a stop signal to varbo at any time.
  //
  // Why `threads: 1` and `threads: 2` once differed for `setsid sleep 20 & echo 6.5`: the old loop stopped
  // checking the deadline once the shell had exited and then waited for EOF, and it killed the shell's
  // process group when it noticed that exit. The background child escaped the kill only if it had already
  // called setsid() (left the group) by then — a race between its exec of setsid and varbo's next wake-up,
  // decided by scheduling, which the thread count (TBB workers spinning on a 2-core machine) shifts. It is not
  // a second code path: measured on the old build, both thread counts gave 0.03 s and 3 s trials in one run
  // of `setsid sleep 3 & echo 6.5`; `setsid sleep 3 & sleep 0.2; echo 6.5` (the child always escapes) took
  // 3 s with either, `(sleep 0.3; setsid sleep 3) & echo 6.5` (never escapes) 0.05 s with either. The
  // supervisor finds the child whatever group or session it is in, and the deadline now always applies.
  for (;;) {
    if (rep.command_ended() && ended_at == Clock::time_point{}) ended_at = Clock::now();
    if (rep.command_ended() && !out_r.open() && !err_r.open()) break;
    // The supervisor vanished without a verdict: it was killed (`kill -9 $PPID` in the command). Whatever
    // holds the output now is the command's orphaned tree, swept below; no need to wait for it.
    if (rep.eof && !rep.have_status && rep.start_errno == 0) break;
    const auto now = Clock::now();
    if (const int sig = interrupt_signal()) {
      r.interrupted = sig;
      break;
    }
    Clock::time_point limit = deadline;
    if (rep.command_ended()) {
      limit = ended_at + seconds(options.output_close_seconds);
      if (now >= limit) {
        r.output_held = true;
        break;
      }
    } else if (now >= deadline) {
      r.timed_out = true;
      break;
    }
    std::vector<pollfd> fds;
    if (out_r.open()) fds.push_back({out_r.fd, POLLIN, 0});
    if (err_r.open()) fds.push_back({err_r.fd, POLLIN, 0});
    if (in_w.open()) fds.push_back({in_w.fd, POLLOUT, 0});
    if (rep.fd.open()) fds.push_back({rep.fd.fd, POLLIN, 0});
    if (stop_fd >= 0) fds.push_back({stop_fd, POLLIN, 0});
    const int n = ::poll(fds.data(), static_cast<nfds_t>(fds.size()), ms_until(limit, now));
    if (n < 0 && errno != EINTR) {
      r.error = fmt::format("poll: {}", std::strerror(errno));
      break;
    }
    if (n <= 0) continue;
    for (const pollfd& p : fds) {
      if (p.revents == 0) continue;
      if (p.fd == out_r.fd) drain(out_r, out);
      else if (p.fd == err_r.fd) drain(err_r, err);
      else if (p.fd == rep.fd.fd) rep.read();
      else if (p.fd == in_w.fd) {
        if (p.revents & (POLLERR | POLLHUP)) {
          in_w.close();  // the child does not read its input: not an error
          continue;
        }
        const ssize_t w = write_no_sigpipe(in_w.fd, input.data() + written, input.size() - written);
        if (w > 0) written += static_cast<std::size_t>(w);
        if ((w < 0 && errno != EAGAIN) || written == input.size()) in_w.close();  // EOF for the reader
      }
    }
  }
  in_w.close();
  // Ended by the supervisor's own deadline (SupervisorPlan::deadline_ms) while varbo could not act (stopped): a
  // timeout all the same, not "killed by signal 15".
  if (!r.timed_out && !r.interrupted && rep.command_ended() && Clock::now() >= deadline && rep.have_status &&
      WIFSIGNALED(rep.status))
    r.timed_out = true;

  // The supervisor ends on its own once the command has ended (after killing what it left); otherwise it is
  // told to stop the tree: SIGTERM, then SIGKILL after the grace. It is our child and not yet reaped, so its
  // pid cannot have been reused.
  if (!rep.command_ended() || r.timed_out || r.interrupted) {
    ::kill(supervisor, SIGTERM);
    // A command can stop its supervisor (`kill -STOP $PPID`); a stopped supervisor would only see SIGTERM
    // at the SIGKILL fallback below, 4 s later (a 2 s timeout took 6.2 s).
    ::kill(supervisor, SIGCONT);
  }
  const auto give_up = Clock::now() + seconds(std::max(0.0, options.kill_grace_seconds) + 4.0);
  int sup_status = 0;
  bool sup_done = false;
  while (!sup_done) {
    pid_t w;
    do {
      w = ::waitpid(supervisor, &sup_status, WNOHANG);
    } while (w < 0 && errno == EINTR);
    if (w == supervisor || w < 0) {
      sup_done = true;
      break;
    }
    if (Clock::now() >= give_up) {
      // A supervisor that does not end (it never should): kill it and the command's group, and wait.
      ::kill(supervisor, SIGKILL);
      if (rep.shell > 0) ::kill(-rep.shell, SIGKILL);
      while (::waitpid(supervisor, &sup_status, 0) < 0 && errno == EINTR) {
      }
      break;
    }
    // Keep reading meanwhile: the last words of a command being stopped (and the exit report).
    std::vector<pollfd> fds;
    if (out_r.open()) fds.push_back({out_r.fd, POLLIN, 0});
    if (err_r.open()) fds.push_back({err_r.fd, POLLIN, 0});
    if (rep.fd.open()) fds.push_back({rep.fd.fd, POLLIN, 0});
    ::poll(fds.data(), static_cast<nfds_t>(fds.size()), 5);
    for (const pollfd& p : fds) {
      if (p.revents == 0) continue;
      if (p.fd == out_r.fd) drain(out_r, out);
      else if (p.fd == err_r.fd) drain(err_r, err);
      else if (p.fd == rep.fd.fd) rep.read();
    }
  }
  if (rep.cgroup_errno != 0)
    note_containment(fmt::format("the command could not enter its cgroup: {}", std::strerror(rep.cgroup_errno)));
  // Whatever is still in the trial's cgroup — everything the command started, when its supervisor was killed
  // (`kill -9 $PPID`), whatever group, session or environment it moved to — is killed at once, and the cgroup
  // removed (the supervisor removed it already unless it was killed).
  const bool cgroup_used = cgroup.active();
  if (cgroup.active() && !cgroup.remove()) {
    static std::atomic<bool> warned{false};
    if (!warned.exchange(true))
      log_warn("external task: a trial's cgroup could not be emptied and removed within 3 s (a process in "
               "uninterruptible sleep?); it is left behind");
  }
  // A supervisor killed by a signal (the command ran `kill -9 $PPID`, or anyone else did) left the command's
  // tree orphaned and running: without a cgroup, and as the second line of defence with one, kill it through
  // its environment token, until none is left (bounded).
  if (WIFSIGNALED(sup_status)) {
    const auto sweep_end = Clock::now() + seconds(3.0);
    while (signal_token(token_entry, SIGKILL) > 0 && Clock::now() < sweep_end)
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    if (rep.shell > 0 && !rep.have_status) ::kill(-rep.shell, SIGKILL);  // not yet reaped: its group is ours
    // Its output closes once those processes are gone: read what is left, briefly.
    const auto read_end = Clock::now() + seconds(0.5);
    while ((out_r.open() || err_r.open()) && Clock::now() < read_end) {
      std::vector<pollfd> fds;
      if (out_r.open()) fds.push_back({out_r.fd, POLLIN, 0});
      if (err_r.open()) fds.push_back({err_r.fd, POLLIN, 0});
      ::poll(fds.data(), static_cast<nfds_t>(fds.size()), 10);
      for (const pollfd& p : fds) {
        if (p.revents == 0) continue;
        if (p.fd == out_r.fd) drain(out_r, out);
        else drain(err_r, err);
      }
    }
  }
  if (out_r.open()) drain(out_r, out);
  if (err_r.open()) drain(err_r, err);
  if (rep.fd.open()) rep.read();
  out.trim();
  err.trim();

  if (rep.start_errno != 0 && rep.shell <= 0) {
    r.started = false;
    r.error = fmt::format("fork: {}", std::strerror(rep.start_errno));
  }
  if (rep.have_status) {
    if (WIFEXITED(rep.status)) {
      r.exited = true;
      r.exit_status = WEXITSTATUS(rep.status);
    } else if (WIFSIGNALED(rep.status)) {
      r.signal = WTERMSIG(rep.status);
    }
  }
  r.in_cgroup = cgroup_used && rep.cgroup_errno == 0 && rep.shell > 0;
  r.seconds = seconds_since(t0);
  return r;
}

}  // namespace varbo::tasks
