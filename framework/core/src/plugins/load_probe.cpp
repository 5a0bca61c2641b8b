#include "load_probe.hpp"

#include <dlfcn.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <signal.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <cstring>

namespace varbo::detail {
namespace {
constexpr int kOpened = 0, kDlopenFailed = 10, kThrew = 11;
}  // namespace

std::optional<std::string> load_crashes(const std::string& path, const std::function<void(void*)>& in_child,
                                        double seconds) {
  const pid_t pid = ::fork();
  if (pid < 0) return std::nullopt;  // no verdict: loaded as before
  if (pid == 0) {
    // The child: its messages (ld.so's assertion, a crashing initializer's output) would repeat the parent's
    // report, so they go nowhere. Only async-signal-safe calls before dlopen; _exit skips the parent's atexit
    // handlers and stdio buffers.
    // A crash kills the child by its signal: the parent's handlers for it (a sanitizer's, which reports and exits
    // 1; a host program's crash reporter) are not the child's business.
    struct sigaction dfl {};
    dfl.sa_handler = SIG_DFL;
    for (const int sig : {SIGSEGV, SIGBUS, SIGILL, SIGFPE, SIGABRT, SIGTRAP, SIGSYS}) ::sigaction(sig, &dfl, nullptr);
    const int null = ::open("/dev/null", O_WRONLY | O_CLOEXEC);
    if (null >= 0) {
      ::dup2(null, STDOUT_FILENO);
      ::dup2(null, STDERR_FILENO);
    }
    void* handle = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (handle == nullptr) ::_exit(kDlopenFailed);
    try {
      in_child(handle);
    } catch (...) {
      ::_exit(kThrew);  // the registration's own errors are the parent's to report
    }
    ::_exit(kOpened);
  }
  int status = 0;
  const timespec tick{0, 2'000'000};  // 2 ms
  const int ticks = static_cast<int>(seconds / 0.002);
  for (int i = 0;; ++i) {
    const pid_t r = ::waitpid(pid, &status, WNOHANG);
    if (r == pid) break;
    if (r < 0) return std::nullopt;
    if (i >= ticks) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      return std::nullopt;
    }
    ::nanosleep(&tick, nullptr);
  }
  if (WIFSIGNALED(status)) {
    const int sig = WTERMSIG(status);
    const char* name = sigabbrev_np(sig);
    return fmt::format("loading it killed a test process with signal {} (SIG{}): the file is damaged or its "
                       "initialization crashes",
                       sig, name ? name : "?");
  }
  if (WIFEXITED(status)) {
    const int code = WEXITSTATUS(status);
    if (code == kOpened || code == kDlopenFailed || code == kThrew) return std::nullopt;
    return fmt::format("loading it ended a test process with exit code {} (the dynamic loader's own check failed: "
                       "a damaged file?)",
                       code);
  }
  return std::nullopt;
}

}  // namespace varbo::detail
