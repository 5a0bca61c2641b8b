#pragma once
// Parallel restarts on TBB, deterministic by construction: slot i is written only by task i and the
// results are reduced in index order, so the thread count never changes a result.
#include <functional>
#include <memory>
#include "varbo/types.hpp"

namespace varbo {

/// Runs body(0..n-1) on the TBB pool (inline when n <= 1).
void parallel_for(Index n, const std::function<void(Index)>& body);

/// Limits TBB to `threads` threads while alive (0 = hardware concurrency).
class ThreadLimit {
 public:
  explicit ThreadLimit(int threads);
  ~ThreadLimit();
  ThreadLimit(const ThreadLimit&) = delete;
  ThreadLimit& operator=(const ThreadLimit&) = delete;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

int hardware_threads();

}  // namespace varbo
