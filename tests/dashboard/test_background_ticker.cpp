// The ticker behind `varbo worker`'s heartbeat and `varbo fit`'s progress line (framework/cli/background_ticker.hpp).
#include <doctest/doctest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <thread>
#include <vector>

#include "varbo/background_ticker.hpp"

using varbo::BackgroundTicker;
using namespace std::chrono_literals;

TEST_CASE("background ticker: ticks missed during a stall are skipped, not made up in a burst") {
  // Red team, session 29: after a 20 s SIGSTOP a worker beating every 0.05 s wrote 900 heartbeats in 2 s. A tick
  // that takes 10 intervals stands in for the stop.
  std::mutex m;
  std::vector<int> ticks;
  {
    BackgroundTicker t([](int k) { return 0.02 * (k + 1); },
                       [&](int k) {
                         {
                           std::lock_guard<std::mutex> lock(m);
                           ticks.push_back(k);
                         }
                         if (k == 0) std::this_thread::sleep_for(200ms);
                         return k < 15;
                       });
    std::this_thread::sleep_for(600ms);
  }
  std::lock_guard<std::mutex> lock(m);
  REQUIRE(ticks.size() >= 2);
  CHECK(ticks[0] == 0);
  CHECK(ticks[1] >= 9);  // the first tick still ahead after the 200 ms stall (tick 9 is due at 200 ms)
}

TEST_CASE("background ticker: a time far beyond the clock's range waits instead of ticking in a loop") {
  // heartbeat_timeout: 1e11 made every deadline overflow into the past: the heartbeat spun.
  std::atomic<int> n{0};
  {
    BackgroundTicker t([](int) { return 1e20; }, [&](int) { return ++n < 1000000; });
    std::this_thread::sleep_for(100ms);
  }
  CHECK(n.load() == 0);
}
