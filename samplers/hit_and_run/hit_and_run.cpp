#include "hit_and_run.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "varbo/errors.hpp"
#include "varbo/log.hpp"
#include "varbo/parallel.hpp"

namespace varbo {

HitAndRunSampler::HitAndRunSampler(HitAndRunOptions options) : options_(options) {
  if (options_.chains < 1 || options_.burn_in < 0 || options_.thinning < 1 || !(options_.width > 0) ||
      options_.max_doublings < 0 || options_.max_shrinks < 1 || !(options_.refresh > 0 && options_.refresh <= 1))
    throw ConfigError("hit_and_run: chains >= 1, burn_in >= 0, thinning >= 1, width > 0, max_doublings >= 0, "
                      "max_shrinks >= 1 and 0 < refresh <= 1 are required");
}

namespace {
// The interval of λ with x + λu inside the box (x inside the box).
void box_chord(const Box& box, const Vec& x, const Vec& u, double& lo, double& hi) {
  lo = -std::numeric_limits<double>::infinity();
  hi = std::numeric_limits<double>::infinity();
  for (Index i = 0; i < x.size(); ++i) {
    if (u[i] == 0.0) continue;
    double a = (box.lower[i] - x[i]) / u[i];
    double b = (box.upper[i] - x[i]) / u[i];
    if (a > b) std::swap(a, b);
    lo = std::max(lo, a);
    hi = std::min(hi, b);
  }
  lo = std::min(lo, 0.0);  // x on the boundary: keep 0 in the chord despite roundoff
  hi = std::max(hi, 0.0);
}
}  // namespace

Vec HitAndRunSampler::step(const RegionConstraint& region, const Vec& x, Rng& rng, HitAndRunStats* stats) const {
  const Index d = x.size();
  Vec u = rng.normal_vec(d);  // isotropic Gaussian ⇒ uniform direction on the sphere
  const double norm = u.norm();
  if (!(norm > 0)) return x;
  u /= norm;
  double box_lo, box_hi;
  box_chord(region.bounds(), x, u, box_lo, box_hi);
  if (stats) ++stats->steps;
  if (!region.has_constraint()) return region.bounds().clamp(x + rng.uniform(box_lo, box_hi) * u);

  auto inside = [&](double lambda) {
    if (stats) ++stats->evaluations;
    return region.contains(region.bounds().clamp(x + lambda * u));
  };
  // Bracket by doubling (Neal 2003, Fig. 4): an initial interval of width w placed at random around 0, doubled
  // until both ends are outside the region or at the box limits. For a convex region the
  // chord is one interval and any bracket containing it makes the shrinkage draw below exactly uniform on it.
  // For a non-convex region (CRBO's C_n is roughly a union of balls) a chord may have several pieces; pieces
  // beyond an outside end are reached only if a doubling jumps over the gap. Neal's acceptance test for that
  // case is omitted (it would cost extra evaluations per step): the chain stays inside the region, but its
  // stationary distribution is then only approximately uniform.
  double L = std::max(box_lo, -options_.width * rng.uniform());
  double R = std::min(box_hi, L + options_.width);
  bool in_L = L > box_lo && inside(L);
  bool in_R = R < box_hi && inside(R);
  for (int k = 0; k < options_.max_doublings && (in_L || in_R); ++k) {
    const double w = R - L;
    // Extend a side whose end is still inside; a random one when both are (Neal's doubling picks at random).
    const bool left = in_L && (!in_R || rng.uniform() < 0.5);
    if (left) {
      L = std::max(box_lo, L - w);
      in_L = L > box_lo && inside(L);
    } else {
      R = std::min(box_hi, R + w);
      in_R = R < box_hi && inside(R);
    }
  }
  // Shrinkage (Neal 2003, Fig. 5): uniform on [L, R]; a rejected λ becomes the new end on its side of 0.
  for (int k = 0; k < options_.max_shrinks; ++k) {
    const double lambda = rng.uniform(L, R);
    const Vec y = region.bounds().clamp(x + lambda * u);
    if (stats) ++stats->evaluations;
    if (region.contains(y)) return y;
    if (lambda < 0)
      L = lambda;
    else
      R = lambda;
  }
  if (stats) ++stats->stuck;
  return x;
}

Mat HitAndRunSampler::sample(const RegionConstraint& region, Index n, Rng& rng) const {
  return sample(region, n, rng, nullptr);
}

std::vector<Vec> HitAndRunSampler::starts_for(const RegionConstraint& region, const Rng& base) const {
  const Box& box = region.bounds();
  const Index d = box.dim();
  // Every seed inside may start a chain (not only the first `chains` of them): a restarted chain draws one.
  const Mat seeds = region.seeds();
  std::vector<Vec> starts;
  for (Index i = 0; i < seeds.rows(); ++i)
    if (seeds.cols() == d && region.contains(seeds.row(i).transpose())) starts.push_back(seeds.row(i).transpose());
  if (!starts.empty()) return starts;
  const Vec centre = 0.5 * (box.lower + box.upper);
  if (region.contains(centre)) {
    starts.push_back(centre);
  } else {
    Rng search = base.stream(0xfeed);
    for (int t = 0; t < 1000 && starts.empty(); ++t) {
      const Vec x = box.lower + box.width().cwiseProduct(search.uniform_vec(d));
      if (region.contains(x)) starts.push_back(x);
    }
  }
  if (starts.empty())
    throw NumericalError("hit_and_run: no feasible starting point (no seed, box centre or random box point "
                         "inside the region)");
  if (seeds.rows() > 0) log_warn("hit_and_run: none of the {} seeds lies inside the region", seeds.rows());
  return starts;
}

Mat HitAndRunSampler::sample(const RegionConstraint& region, Index n, Rng& rng, HitAndRunStats* stats) const {
  const Box& box = region.bounds();
  const Index d = box.dim();
  if (n <= 0) return Mat(0, d);
  const std::lock_guard<std::mutex> lock(mutex_);
  const std::uint64_t draw = rng.next();  // one draw of the caller's stream per call: repeated calls differ
  const Rng base(draw);
  if (!options_.keep_chains || (!chains_.empty() && chains_.front().size() != d)) chains_.clear();
  if (previous_.cols() != d) previous_.resize(0, d);

  // The previous call's newest samples that are still inside: at most (1 − refresh)·n of them.
  std::vector<Index> kept;
  const Index keep_at_most = options_.keep_chains ? static_cast<Index>((1.0 - options_.refresh) * n) : 0;
  for (Index i = 0; i < previous_.rows() && static_cast<Index>(kept.size()) < keep_at_most; ++i)
    if (region.contains(previous_.row(i).transpose())) kept.push_back(i);
  const Index n_new = n - static_cast<Index>(kept.size());

  // Chains: as many as options_.chains (a chain produces at least one sample when n_new allows).
  const Index chains = std::max<Index>(1, std::min(options_.chains, n_new));
  if (static_cast<Index>(chains_.size()) < chains) chains_.resize(static_cast<std::size_t>(chains));
  std::vector<bool> restart(static_cast<std::size_t>(chains));
  bool any_restart = false;
  for (Index c = 0; c < chains; ++c) {
    const Vec& x = chains_[static_cast<std::size_t>(c)];
    restart[static_cast<std::size_t>(c)] = x.size() != d || !region.contains(x);
    any_restart = any_restart || restart[static_cast<std::size_t>(c)];
  }
  const std::vector<Vec> starts = any_restart ? starts_for(region, base) : std::vector<Vec>{};

  Mat out(n, d);
  std::vector<HitAndRunStats> chain_stats(static_cast<std::size_t>(chains));
  // Chain c produces new rows c, c + chains, c + 2·chains, ... : disjoint slots, so threads never interact.
  parallel_for(chains, [&](Index c) {
    const auto slot = static_cast<std::size_t>(c);
    Rng r = base.stream(1, static_cast<std::uint64_t>(c));
    HitAndRunStats* s = &chain_stats[slot];
    // A restarted chain starts at a seed; a kept one goes on from its last point. Either takes `burn_in` steps
    // first: the same cost per call as restarting every chain, but a kept chain's steps add up across calls.
    Vec x = restart[slot] ? starts[static_cast<std::size_t>(r.index(static_cast<Index>(starts.size())))] : chains_[slot];
    for (Index k = 0; k < options_.burn_in; ++k) x = step(region, x, r, s);
    for (Index row = c; row < n_new; row += chains) {
      for (Index k = 0; k < options_.thinning; ++k) x = step(region, x, r, s);
      out.row(row) = x.transpose();
    }
    chains_[slot] = x;
  });
  for (std::size_t j = 0; j < kept.size(); ++j) out.row(n_new + static_cast<Index>(j)) = previous_.row(kept[j]);
  previous_ = out;
  if (stats) {
    for (const auto& s : chain_stats) {
      stats->steps += s.steps;
      stats->stuck += s.stuck;
      stats->evaluations += s.evaluations;
    }
  }
  return out;
}

}  // namespace varbo
