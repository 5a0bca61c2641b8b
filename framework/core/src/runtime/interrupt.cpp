#include "varbo/interrupt.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <mutex>

namespace varbo {

namespace {

std::atomic<int> g_signal{0};
// A self-pipe: the handler writes one byte that nobody reads, so the read end stays readable for every
// poll() that watches it, however many there are.
int g_pipe[2] = {-1, -1};
// SIGQUIT (Ctrl-\) too: it killed varbo at once and left the running trial pending (audit, session 47).
constexpr int kStopSignals[] = {SIGINT, SIGTERM, SIGHUP, SIGQUIT};
constexpr int kStops = static_cast<int>(sizeof kStopSignals / sizeof kStopSignals[0]);
// A stop signal that arrived ignored stays ignored: `nohup varbo worker ...` (SIGHUP) and `varbo worker ... &` in a
// script (a non-interactive shell ignores SIGINT for background jobs) were stopped by what their user had shut
// out (red team, session 29). Read once, before any handler is installed.
bool g_ignored[kStops] = {};

void on_stop_signal(int sig) {
  const int saved = errno;
  int expected = 0;
  g_signal.compare_exchange_strong(expected, sig);
  if (g_pipe[1] >= 0) {
    const char byte = 1;
    [[maybe_unused]] ssize_t ignored = ::write(g_pipe[1], &byte, 1);
  }
  // One-shot for all of them: a second Ctrl-C (or a SIGTERM after it) kills at once.
  struct sigaction dfl;
  std::memset(&dfl, 0, sizeof dfl);
  dfl.sa_handler = SIG_DFL;
  for (int i = 0; i < kStops; ++i)
    if (!g_ignored[i]) ::sigaction(kStopSignals[i], &dfl, nullptr);
  errno = saved;
}

}  // namespace

void install_interrupt_handlers() {
  static std::once_flag once;
  std::call_once(once, [] {
    if (::pipe2(g_pipe, O_CLOEXEC | O_NONBLOCK) != 0) g_pipe[0] = g_pipe[1] = -1;
    struct sigaction sa;
    std::memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_stop_signal;
    sigemptyset(&sa.sa_mask);
    for (int s : kStopSignals) sigaddset(&sa.sa_mask, s);
    sa.sa_flags = SA_RESTART;
    for (int i = 0; i < kStops; ++i) {
      struct sigaction current;
      g_ignored[i] = ::sigaction(kStopSignals[i], nullptr, &current) == 0 && current.sa_handler == SIG_IGN;
      if (!g_ignored[i]) ::sigaction(kStopSignals[i], &sa, nullptr);
    }
  });
}

bool stop_signal_ignored(int sig) {
  for (int i = 0; i < kStops; ++i)
    if (kStopSignals[i] == sig) return g_ignored[i];
  return false;
}

int interrupt_signal() { return g_signal.load(); }

namespace {
std::atomic<int (*)()> g_host_poll{nullptr};
}

void set_host_interrupt_poll(int (*poll)()) { g_host_poll.store(poll); }

int interrupt_requested() {
  if (const int sig = g_signal.load(); sig != 0) return sig;
  int (*poll)() = g_host_poll.load();
  return poll ? poll() : 0;
}

int interrupt_fd() { return g_pipe[0]; }

std::string signal_name(int sig) {
  switch (sig) {
    case SIGINT: return "SIGINT";
    case SIGTERM: return "SIGTERM";
    case SIGHUP: return "SIGHUP";
    case SIGKILL: return "SIGKILL";
    case SIGQUIT: return "SIGQUIT";
    default: return fmt::format("signal {}", sig);
  }
}

Interrupted::Interrupted(int sig)
    : std::runtime_error(fmt::format("interrupted by {}", signal_name(sig))), signal_(sig) {}

}  // namespace varbo
