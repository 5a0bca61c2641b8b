// The dashboard server's worker threads (dashboard_http.cpp hands cpp-httplib one of these as its task queue).
//
// cpp-httplib's own ThreadPool has a fixed number of threads, each held by one connection until its request has
// arrived (or the read timeout): 8 idle or slow (slowloris) clients stalled every other request, and 300 idle
// connections kept a GET waiting > 30 s (docs/dashboard.md, "Red-team pass"). This pool starts a thread whenever
// the queued connections outnumber the threads free to take them, up to a cap, so slow clients only hold threads
// of their own; past the cap, connections queue.
//
// Header-only and free of cpp-httplib, so that tests/dashboard/test_growing_pool.cpp can drive it directly.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace varbo::cli {

class GrowingPool {
 public:
  explicit GrowingPool(std::size_t max_threads) : max_threads_(max_threads < 1 ? 1 : max_threads) {}
  GrowingPool(const GrowingPool&) = delete;
  GrowingPool& operator=(const GrowingPool&) = delete;
  ~GrowingPool() { shutdown(); }

  void enqueue(std::function<void()> job) {
    std::unique_lock<std::mutex> lock(mutex_);
    jobs_.push_back(std::move(job));
    // A thread that was woken for an earlier job but has not taken it yet still counts as idle, and a thread just
    // started has not counted itself yet: compare the queue with all threads that will take a job from it. (Testing
    // `idle == 0` alone let a burst of connections all be promised to the same idle thread; behind slow clients
    // holding every other thread, a request then waited until they left — a 60 s stall in CI.)
    if (jobs_.size() > idle_ + starting_ && threads_.size() < max_threads_) {
      ++starting_;
      threads_.emplace_back([this] { work(); });
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
    for (auto& t : threads_)
      if (t.joinable()) t.join();
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
  void work() {
    std::unique_lock<std::mutex> lock(mutex_);
    --starting_;
    for (;;) {
      ++idle_;
      cond_.wait(lock, [&] { return stop_ || !jobs_.empty(); });
      --idle_;
      if (jobs_.empty()) return;  // stopping, nothing left
      std::function<void()> job = std::move(jobs_.front());
      jobs_.pop_front();
      lock.unlock();
      job();
      lock.lock();
    }
  }

  const std::size_t max_threads_;
  mutable std::mutex mutex_;
  std::condition_variable cond_;
  std::deque<std::function<void()>> jobs_;
  std::vector<std::thread> threads_;
  std::size_t idle_ = 0;
  std::size_t starting_ = 0;
  bool stop_ = false;
};

}  // namespace varbo::cli
