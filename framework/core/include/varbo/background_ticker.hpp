#pragma once
// A background thread that runs a tick at scheduled times until it is destroyed: `varbo worker`'s heartbeat, `varbo
// run`'s on a database study (run_liveness.hpp) and `varbo fit`'s progress line. Destruction wakes the thread at once (it never waits for the next tick) and joins it.
#include <algorithm>
#include <chrono>
#include <limits>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>

namespace varbo {

class BackgroundTicker {
 public:
  /// `at(k)`: seconds after construction at which tick k (k = 0, 1, ...) runs; `tick(k)` returns false to stop.
  /// Ticks run on the thread, under the ticker's lock, so the destructor waits for a running tick to end.
  BackgroundTicker(std::function<double(int)> at, std::function<bool(int)> tick)
      : at_(std::move(at)), tick_(std::move(tick)), thread_([this] { run(); }) {}
  ~BackgroundTicker() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      done_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  BackgroundTicker(const BackgroundTicker&) = delete;
  BackgroundTicker& operator=(const BackgroundTicker&) = delete;

 private:
  void run() {
    const auto t0 = std::chrono::steady_clock::now();
    // Capped at ~30 years: a time past the clock's 64-bit nanosecond range overflowed into the past, and the
    // ticker ticked in a loop (heartbeat_timeout: 1e11; red team, session 29).
    const auto time_of = [&](int k) {
      return t0 + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                      std::chrono::duration<double>(std::min(at_(k), 1e9)));
    };
    std::unique_lock<std::mutex> lock(mutex_);
    for (int k = 0;;) {
      if (cv_.wait_until(lock, time_of(k), [this] { return done_; })) return;
      if (!tick_(k)) return;
      // Ticks missed while the process was stopped (Ctrl-Z, SIGSTOP) are not made up in a burst: 900 heartbeat
      // writes in the 2 s after a 20 s stop. The next tick is the first still ahead.
      const auto now = std::chrono::steady_clock::now();
      do ++k;
      while (k < std::numeric_limits<int>::max() && time_of(k) <= now);
    }
  }

  std::function<double(int)> at_;
  std::function<bool(int)> tick_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool done_ = false;
  std::thread thread_;  ///< last: starts once everything it uses is constructed
};

}  // namespace varbo
