#pragma once
// Stopping cleanly on SIGINT, SIGTERM, SIGHUP or SIGQUIT. A long command (`varbo run`) installs the handlers; the
// first signal is only recorded, and work that waits (an external command's trial) watches interrupt_fd()
// and ends what it runs. The handlers are one-shot: a second signal gets the default action and kills
// at once (the study store stays consistent either way: every result is committed before it is shown).
#include <stdexcept>
#include <string>

namespace varbo {

/// Installs the one-shot handlers for SIGINT, SIGTERM, SIGHUP and SIGQUIT (idempotent). One that the process started with
/// ignored (nohup, a background job of a script) is left ignored.
void install_interrupt_handlers();
/// Whether `sig` (SIGINT, SIGTERM, SIGHUP or SIGQUIT) was ignored when install_interrupt_handlers() first ran.
bool stop_signal_ignored(int sig);
/// The signal that asked this process to stop, or 0.
int interrupt_signal();
/// An embedding host's own stop request, for a host that keeps the signals to itself (the Python module: a Ctrl-C
/// its interpreter has seen): returns a signal number or 0. One per process; null = none.
void set_host_interrupt_poll(int (*poll)());
/// interrupt_signal(), else the host's poll (set_host_interrupt_poll): what a wait that a stop ends consults (the
/// study store's wait for its write lock).
int interrupt_requested();
/// Readable (poll POLLIN) once a stop signal arrived; -1 until install_interrupt_handlers().
int interrupt_fd();
/// "SIGTERM", "SIGINT", ... ("signal N" for others).
std::string signal_name(int sig);

/// Thrown once the interrupted work is recorded; the command exits with 128 + signal.
class Interrupted : public std::runtime_error {
 public:
  explicit Interrupted(int sig);
  int signal() const { return signal_; }

 private:
  int signal_;
};

}  // namespace varbo
