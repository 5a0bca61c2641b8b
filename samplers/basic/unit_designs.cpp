#include "unit_designs.hpp"

#include <algorithm>
#include <boost/random/sobol.hpp>
#include <numeric>

#include "varbo/errors.hpp"

namespace varbo::sampling {

Mat uniform_unit(Index n, Index d, Rng& rng) {
  Mat X(n, d);
  for (Index i = 0; i < n; ++i)
    for (Index j = 0; j < d; ++j) X(i, j) = rng.uniform();
  return X;
}

Mat latin_hypercube_unit(Index n, Index d, Rng& rng) {
  Mat X(n, d);
  std::vector<Index> perm(static_cast<std::size_t>(n));
  for (Index j = 0; j < d; ++j) {
    std::iota(perm.begin(), perm.end(), Index{0});
    // Fisher–Yates with our own stream (std::shuffle's algorithm is implementation-defined).
    for (Index i = n - 1; i > 0; --i) std::swap(perm[static_cast<std::size_t>(i)],
                                                perm[static_cast<std::size_t>(rng.index(i + 1))]);
    for (Index i = 0; i < n; ++i) {
      const double v = (static_cast<double>(perm[static_cast<std::size_t>(i)]) + rng.uniform()) /
                       static_cast<double>(n);
      X(i, j) = std::min(v, std::nextafter(1.0, 0.0));  // stay in [0, 1) despite rounding
    }
  }
  return X;
}

struct SobolSequence::Engine {
  explicit Engine(std::size_t d) : sobol(d) {}
  boost::random::sobol sobol;
};

SobolSequence::SobolSequence(Index d, bool scramble, Rng& rng) : d_(d) {
  if (d < 1 || d > kSobolMaxDim)
    throw ConfigError("sobol: dimension " + std::to_string(d) + " is outside the supported range 1.." +
                      std::to_string(kSobolMaxDim) + " (its direction numbers); use lhs or uniform");
  engine_ = std::make_unique<Engine>(static_cast<std::size_t>(d));
  shift_.assign(static_cast<std::size_t>(d), 0);
  if (scramble)
    for (auto& s : shift_) s = rng.next();
}

SobolSequence::~SobolSequence() = default;

Vec SobolSequence::next() {
  Vec x(d_);
  for (Index j = 0; j < d_; ++j) {
    // 64-bit digits, shifted, then the top 53 bits as a double in [0, 1).
    const std::uint64_t digits = static_cast<std::uint64_t>(engine_->sobol()) ^ shift_[static_cast<std::size_t>(j)];
    x[j] = static_cast<double>(digits >> 11) * 0x1.0p-53;
  }
  return x;
}

Mat SobolSequence::next(Index n) {
  Mat X(n, d_);
  for (Index i = 0; i < n; ++i) X.row(i) = next().transpose();
  return X;
}

}  // namespace varbo::sampling
