// The dashboard server's worker threads (dashboard_http.cpp hands cpp-httplib one of these as its task queue).
//
// cpp-httplib's own ThreadPool has a fixed number of threads, each held by one connection until its request has
// arrived (or the read timeout): 8 idle or slow (slowloris) clients stalled every other request, and 300 idle
// connections kept a GET waiting > 30 s (docs/dashboard.md, "Red-team pass"). This pool starts a thread whenever
// the queued connections outnumber the threads free to take them, up to a cap, so slow clients only hold threads
// of their own; past the cap, connections queue. A thread idle for `idle_timeout` leaves (down to `min_threads`):
// a burst of 20 slow clients left 22 threads and their heaps (1.1 GB) for the server's lifetime (red team,
// session 29). When every thread is idle and nothing is queued, `on_idle` runs (the server returns freed heap).
//
// Header-only and free of cpp-httplib, so that tests/dashboard/test_growing_pool.cpp can drive it directly.
#pragma once

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <list>
#include <mutex>
#include <thread>
#include <vector>

namespace varbo::cli {

class GrowingPool {
 public:
  explicit GrowingPool(std::size_t max_threads, std::chrono::milliseconds idle_timeout = std::chrono::seconds(10),
                       std::size_t min_threads = 2, std::function<void()> on_idle = {})
      : max_threads_(max_threads < 1 ? 1 : max_threads),
        min_threads_(min_threads),
        idle_timeout_(idle_timeout),
        on_idle_(std::move(on_idle)) {}
  GrowingPool(const GrowingPool&) = delete;
  GrowingPool& operator=(const GrowingPool&) = delete;
  ~GrowingPool() { shutdown(); }

  void enqueue(std::function<void()> job) {
    join_retired();
    std::unique_lock<std::mutex> lock(mutex_);
    jobs_.push_back(std::move(job));
    // A thread that was woken for an earlier job but has not taken it yet still counts as idle, and a thread just
    // started has not counted itself yet: compare the queue with all threads that will take a job from it. (Testing
    // `idle == 0` alone let a burst of connections all be promised to the same idle thread; behind slow clients
    // holding every other thread, a request then waited until they left — a 60 s stall in CI.)
    if (jobs_.size() > idle_ + starting_ && threads_.size() < max_threads_) {
      ++starting_;
      threads_.emplace_back();
      auto self = std::prev(threads_.end());
      *self = std::thread([this, self] { work(self); });
    } else {
      cond_.notify_one();
    }
  }

  /// Lets the queued jobs finish, then joins every thread. Idempotent.
  void shutdown() {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      stop_ = true;
    }
    cond_.notify_all();
    // Threads leave the list only by retiring, which a stopping pool no longer does: the list is stable now.
    for (auto& t : threads_)
      if (t.joinable()) t.join();
    join_retired();
  }

  std::size_t threads() const {
    std::unique_lock<std::mutex> lock(mutex_);
    return threads_.size();
  }
  std::size_t idle() const {
    std::unique_lock<std::mutex> lock(mutex_);
    return idle_;
  }

 private:
  using Slot = std::list<std::thread>::iterator;

  void work(Slot self) {
    std::unique_lock<std::mutex> lock(mutex_);
    --starting_;
    for (;;) {
      ++idle_;
      const bool woken = cond_.wait_for(lock, idle_timeout_, [&] { return stop_ || !jobs_.empty(); });
      --idle_;
      if (!woken && threads_.size() > min_threads_) {
        // Idle too long and not needed: leave. The thread object moves to retired_, joined by the next
        // enqueue or the shutdown (a thread cannot join itself).
        retired_.splice(retired_.end(), threads_, self);
        return;
      }
      if (!woken) continue;
      if (jobs_.empty()) return;  // stopping, nothing left
      std::function<void()> job = std::move(jobs_.front());
      jobs_.pop_front();
      lock.unlock();
      job();
      job = nullptr;  // the connection's buffers are freed before on_idle looks at the heap
      lock.lock();
      if (on_idle_ && jobs_.empty() && idle_ + 1 == threads_.size() && !stop_) {
        lock.unlock();
        on_idle_();
        lock.lock();
      }
    }
  }

  void join_retired() {
    std::list<std::thread> done;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      done.swap(retired_);
    }
    for (auto& t : done)
      if (t.joinable()) t.join();
  }

  const std::size_t max_threads_, min_threads_;
  const std::chrono::milliseconds idle_timeout_;
  const std::function<void()> on_idle_;
  mutable std::mutex mutex_;
  std::condition_variable cond_;
  std::deque<std::function<void()>> jobs_;
  std::list<std::thread> threads_, retired_;
  std::size_t idle_ = 0;
  std::size_t starting_ = 0;
  bool stop_ = false;
};

}  // namespace varbo::cli
