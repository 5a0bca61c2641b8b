#include "varbo/parallel.hpp"

#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>

namespace varbo {

void parallel_for(Index n, const std::function<void(Index)>& body) {
  if (n <= 0) return;
  if (n == 1) {
    body(0);
    return;
  }
  // Grain size 1: each restart is expensive and independent.
  tbb::parallel_for(tbb::blocked_range<Index>(0, n, 1), [&](const tbb::blocked_range<Index>& r) {
    for (Index i = r.begin(); i != r.end(); ++i) body(i);
  });
}

struct ThreadLimit::Impl {
  std::unique_ptr<tbb::global_control> control;
};

ThreadLimit::ThreadLimit(int threads) : impl_(std::make_unique<Impl>()) {
  if (threads > 0)
    impl_->control = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                           static_cast<std::size_t>(threads));
}
ThreadLimit::~ThreadLimit() = default;

int hardware_threads() { return tbb::info::default_concurrency(); }

}  // namespace varbo
