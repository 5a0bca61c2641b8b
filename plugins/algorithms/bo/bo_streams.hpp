#pragma once
// The random streams of a bo run: one per (purpose, evaluation index), derived from the run seed (Rng::stream),
// so a suggestion depends only on the seed, the data and its index — whatever the thread count.
#include <cstdint>

namespace varbo::bo {

enum Stream : std::uint64_t {
  kDesign = 1, kFit = 2, kAcquisition = 3, kOptimize = 4, kEpsilon = 5, kRandom = 6, kRecommend = 7, kFreshDesign = 8,
  kPendingAway = 9, kGlobalProbe = 10, kRefineKnown = 11,
  kBackoffNew = 12
};

}  // namespace varbo::bo
