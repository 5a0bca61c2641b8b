#include "region_samplers.hpp"

#include "varbo/log.hpp"

namespace varbo::sampling {

Mat fill_region(const RegionConstraint& region, Index n, const std::function<Mat(Index)>& next_batch,
                Index max_draws, const char* who) {
  const Box& box = region.bounds();
  const Index d = box.dim();
  Mat out(std::max<Index>(n, 0), d);
  if (n <= 0) return out;
  const Vec width = box.width();
  Index found = 0, drawn = 0;
  while (found < n && drawn < max_draws) {
    const Mat U = next_batch(n - found);
    for (Index i = 0; i < U.rows() && found < n; ++i) {
      ++drawn;
      const Vec x = box.lower + (U.row(i).transpose().array() * width.array()).matrix();
      if (region.has_constraint() && !region.contains(x)) continue;
      out.row(found++) = x.transpose();
    }
  }
  if (found < n) {
    // Said once (per sampler kind); the counts of each call at debug level: a small feasible set (constraints
    // around a corner of the box) repeated it on every trial, 371 times in a run of 40 (red team, session 30).
    log_debug("{} sampler: only {} of {} points found inside the region's constraint after {} draws", who, found, n,
              drawn);
    log_warn_once(fmt::format("{} sampler: fewer points than asked found inside the region's constraint: the "
                              "feasible set is a small part of the box (constraints that leave little room?); said "
                              "once, each shortfall with -v",
                              who));
    out.conservativeResize(found, d);
  }
  return out;
}

namespace {
Index max_draws(const RegionConstraint& region, Index n) {
  return region.has_constraint() ? std::max<Index>(n, 1) * kMaxDrawsPerPoint : n;
}
}  // namespace

Mat UniformSampler::sample(const RegionConstraint& region, Index n, Rng& rng) const {
  const Index d = region.bounds().dim();
  return fill_region(
      region, n, [&](Index k) { return uniform_unit(k, d, rng); }, max_draws(region, n), "uniform");
}

Mat LatinHypercubeSampler::sample(const RegionConstraint& region, Index n, Rng& rng) const {
  const Index d = region.bounds().dim();
  // With a constraint, each batch is a fresh n-point hypercube; the accepted subset is not stratified.
  return fill_region(
      region, n, [&](Index) { return latin_hypercube_unit(n, d, rng); }, max_draws(region, n), "lhs");
}

Mat SobolSampler::sample(const RegionConstraint& region, Index n, Rng& rng) const {
  SobolSequence sequence(region.bounds().dim(), scramble_, rng);
  // Consecutive points of one sequence: rejection keeps the low-discrepancy order of what remains.
  return fill_region(
      region, n, [&](Index k) { return sequence.next(k); }, max_draws(region, n), "sobol");
}

}  // namespace varbo::sampling
