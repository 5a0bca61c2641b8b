#pragma once
// Riding out a database restart or a network cut (docs/studies.md, "When a machine dies"): a process that stays up
// for hours — `varbo worker`, `varbo run` on a PostgreSQL study — retries what the lost connection cut short
// instead of ending the night's trials at the first outage.
#include <algorithm>
#include <chrono>
#include <functional>
#include <string>
#include <thread>

#include "varbo/log.hpp"
#include "varbo/store.hpp"

namespace varbo {

/// Runs `f`, retrying with backoff (0.5 s doubling to 15 s) while it throws StoreConnectionError, for at most
/// `limit_seconds` (0: no retry) and while `stop()` (if given) is false; the last error is rethrown. Before each
/// retry, `before_retry` (if given) runs inside the same guard (e.g. to take a lost lock again). A failed attempt
/// writes nothing (the server rolls its transaction back), so retrying is safe; an attempt whose COMMIT was cut may
/// have landed, which `f` must find out itself. `who` starts the warning ("worker host:1:ab", "run runs/a").
template <class F>
auto retry_while_unreachable(double limit_seconds, const std::string& who, const std::function<bool()>& stop, F&& f,
                             const std::function<void()>& before_retry = {}) -> decltype(f()) {
  const auto start = std::chrono::steady_clock::now();
  double wait = 0.5;
  bool retry = false;
  for (;;) {
    try {
      if (retry && before_retry) before_retry();
      return f();
    } catch (const StoreConnectionError& e) {
      const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      // The last attempt comes at the limit: a doubled wait that would overshoot it is cut short (with
      // --reconnect-timeout 3 a worker gave up after 1.5 s; red team, session 25).
      const double remaining = limit_seconds - elapsed;
      if (remaining <= 0.05 || (stop && stop())) throw;
      const double now_wait = std::min(wait, remaining);
      log_warn("{}: {}; retrying in {:.1f} s", who, e.what(), now_wait);
      std::this_thread::sleep_for(std::chrono::duration<double>(now_wait));
      wait = std::min(15.0, 2 * wait);
      retry = true;
    }
  }
}

}  // namespace varbo
