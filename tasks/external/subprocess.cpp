#include "subprocess.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <vector>

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

// Keeps at most `cap` bytes, dropping from the front: the answer is at the end of the output.
void append_tail(std::string& s, const char* data, std::size_t n, std::size_t cap) {
  s.append(data, n);
  if (s.size() > cap) s.erase(0, s.size() - cap);
}

// Reads what is available; returns false on EOF or a hard error (the fd is then closed).
bool drain(Fd& fd, std::string& sink, std::size_t cap) {
  char buf[65536];
  for (;;) {
    const ssize_t n = ::read(fd.fd, buf, sizeof buf);
    if (n > 0) {
      append_tail(sink, buf, static_cast<std::size_t>(n), cap);
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

}  // namespace

std::string ProcessResult::status_text() const {
  if (!started) return "could not start: " + error;
  if (timed_out) return fmt::format("timed out after {:.3g} s (process group killed)", seconds);
  if (exited) return fmt::format("exit status {}", exit_status);
  return fmt::format("killed by signal {} ({})", signal, ::strsignal(signal));
}

ProcessResult run_shell(const std::string& command, const std::string& input, const ProcessOptions& options) {
  ProcessResult r;
  const auto t0 = Clock::now();
  Fd in_r, in_w, out_r, out_w, err_r, err_w;
  if (!make_pipe(in_r, in_w) || !make_pipe(out_r, out_w) || !make_pipe(err_r, err_w)) {
    r.error = fmt::format("pipe: {}", std::strerror(errno));
    return r;
  }
  // Everything the child needs is prepared before fork: after fork only async-signal-safe calls.
  const char* argv[] = {"sh", "-c", command.c_str(), nullptr};
  const char* workdir = options.working_directory.empty() ? nullptr : options.working_directory.c_str();

  const pid_t pid = ::fork();
  if (pid < 0) {
    r.error = fmt::format("fork: {}", std::strerror(errno));
    return r;
  }
  if (pid == 0) {
    ::setpgid(0, 0);  // own process group, so a timeout can kill the shell and everything it started
    ::dup2(in_r.fd, STDIN_FILENO);
    ::dup2(out_w.fd, STDOUT_FILENO);
    ::dup2(err_w.fd, STDERR_FILENO);
    struct sigaction dfl;
    std::memset(&dfl, 0, sizeof dfl);
    dfl.sa_handler = SIG_DFL;
    ::sigaction(SIGPIPE, &dfl, nullptr);
    sigset_t none;
    sigemptyset(&none);
    ::sigprocmask(SIG_SETMASK, &none, nullptr);
    if (workdir != nullptr && ::chdir(workdir) != 0) {
      static const char msg[] = "varbo external task: cannot change to the working directory\n";
      [[maybe_unused]] ssize_t ignored = ::write(STDERR_FILENO, msg, sizeof msg - 1);
      ::_exit(126);
    }
    ::execve("/bin/sh", const_cast<char* const*>(argv), environ);
    ::_exit(127);
  }
  ::setpgid(pid, pid);  // also from the parent: no race with a kill before the child's own setpgid
  r.started = true;
  in_r.close();
  out_w.close();
  err_w.close();
  set_nonblocking(in_w.fd);
  set_nonblocking(out_r.fd);
  set_nonblocking(err_r.fd);

  std::size_t written = 0;
  if (input.empty()) in_w.close();
  const auto deadline = t0 + std::chrono::duration_cast<Clock::duration>(
                                 std::chrono::duration<double>(options.timeout_seconds));
  bool child_done = false;  // exited (still a zombie: waitid WNOWAIT keeps its pid and group reserved)

  auto kill_group = [&](int sig) { ::kill(-pid, sig); };

  // Until the shell has exited and both output pipes are at EOF (a command that closes its stdout and
  // keeps running is still bounded by the deadline).
  for (;;) {
    if (!child_done) {
      siginfo_t info;
      std::memset(&info, 0, sizeof info);
      if (::waitid(P_PID, static_cast<id_t>(pid), &info, WEXITED | WNOHANG | WNOWAIT) == 0 && info.si_pid == pid) {
        child_done = true;
        // The shell is gone; background jobs it left would hold the pipes open forever.
        kill_group(SIGKILL);
      }
    }
    if (child_done && !out_r.open() && !err_r.open()) break;
    const auto now = Clock::now();
    if (!child_done && now >= deadline) {
      r.timed_out = true;
      break;
    }
    int wait_ms = 50;
    if (!child_done)
      wait_ms = static_cast<int>(std::clamp<long long>(
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline - now).count() + 1, 1, 50));
    std::vector<pollfd> fds;
    if (out_r.open()) fds.push_back({out_r.fd, POLLIN, 0});
    if (err_r.open()) fds.push_back({err_r.fd, POLLIN, 0});
    if (in_w.open()) fds.push_back({in_w.fd, POLLOUT, 0});
    const int n = ::poll(fds.data(), static_cast<nfds_t>(fds.size()), wait_ms);
    if (n < 0 && errno != EINTR) {
      r.error = fmt::format("poll: {}", std::strerror(errno));
      kill_group(SIGKILL);  // so the wait below cannot block
      break;
    }
    if (n <= 0) continue;
    for (const pollfd& p : fds) {
      if (p.revents == 0) continue;
      if (p.fd == out_r.fd) drain(out_r, r.out, options.max_stdout);
      else if (p.fd == err_r.fd) drain(err_r, r.err, options.max_stderr);
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

  if (r.timed_out) {
    // Polite first (a simulator may want to clean up), then certain.
    kill_group(SIGTERM);
    const auto hard = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                         std::chrono::duration<double>(options.kill_grace_seconds));
    while (Clock::now() < hard) {
      siginfo_t info;
      std::memset(&info, 0, sizeof info);
      // WNOWAIT: the zombie keeps the group id reserved until the SIGKILL below has been sent.
      if (::waitid(P_PID, static_cast<id_t>(pid), &info, WEXITED | WNOHANG | WNOWAIT) == 0 && info.si_pid == pid)
        break;
      ::usleep(5000);
    }
    kill_group(SIGKILL);
  }
  if (out_r.open()) drain(out_r, r.out, options.max_stdout);
  if (err_r.open()) drain(err_r, r.err, options.max_stderr);

  int status = 0;
  pid_t w;
  do {
    w = ::waitpid(pid, &status, 0);
  } while (w < 0 && errno == EINTR);
  if (w == pid) {
    if (WIFEXITED(status)) {
      r.exited = true;
      r.exit_status = WEXITSTATUS(status);
    } else if (WIFSIGNALED(status)) {
      r.signal = WTERMSIG(status);
    }
  }
  r.seconds = seconds_since(t0);
  return r;
}

}  // namespace varbo::tasks
