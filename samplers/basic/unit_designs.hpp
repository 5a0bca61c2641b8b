#pragma once
// Point sets in the unit cube [0, 1)^d: i.i.d. uniform, Latin hypercube and (digitally shifted) Sobol.
#include <memory>

#include "varbo/types.hpp"

namespace varbo::sampling {

/// n i.i.d. uniform points (rows).
Mat uniform_unit(Index n, Index d, Rng& rng);

/// Latin hypercube: in every dimension each of the n strata [k/n, (k+1)/n) holds exactly one point,
/// at a uniform position inside it (McKay, Beckman & Conover 1979).
Mat latin_hypercube_unit(Index n, Index d, Rng& rng);

/// The most dimensions SobolSequence has direction numbers for.
inline constexpr Index kSobolMaxDim = 3667;

/// The Sobol sequence of Boost.Random (Joe–Kuo direction numbers, up to kSobolMaxDim dimensions). With `scramble`,
/// a random digital shift (an XOR of every coordinate's 64-bit digits with a per-dimension random word,
/// drawn from rng at construction) randomizes the sequence while keeping its (t, m, s)-net structure.
class SobolSequence {
 public:
  SobolSequence(Index d, bool scramble, Rng& rng);
  ~SobolSequence();
  SobolSequence(const SobolSequence&) = delete;
  SobolSequence& operator=(const SobolSequence&) = delete;
  /// The next point of the sequence, in [0, 1)^d.
  Vec next();
  /// The next n points as rows.
  Mat next(Index n);
  Index dim() const { return d_; }

 private:
  struct Engine;
  Index d_;
  std::unique_ptr<Engine> engine_;
  std::vector<std::uint64_t> shift_;
};

}  // namespace varbo::sampling
