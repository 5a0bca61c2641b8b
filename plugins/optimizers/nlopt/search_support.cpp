#include "search_support.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "local_search.hpp"
#include "varbo/parallel.hpp"

namespace varbo::nlopt_plugin {

Mat feasible_rows(const RegionConstraint& region, const Mat& X) {
  const Box& box = region.bounds();
  Mat out(X.rows(), box.dim());
  Index k = 0;
  for (Index i = 0; i < X.rows(); ++i) {
    if (X.cols() != box.dim()) break;
    const Vec x = box.clamp(X.row(i).transpose());
    if (!x.allFinite() || (region.has_constraint() && !region.contains(x))) continue;
    out.row(k++) = x.transpose();
  }
  out.conservativeResize(k, box.dim());
  return out;
}

Vec evaluate_rows(const DifferentiableFunction& f, const Mat& X) {
  const Index n = X.rows();
  Vec values(n);
  // Chunks amortize the task overhead of cheap evaluations (an acquisition at N = 100 costs a few µs).
  constexpr Index kChunk = 32;
  const Index chunks = (n + kChunk - 1) / kChunk;
  parallel_for(chunks, [&](Index c) {
    const Index end = std::min(n, (c + 1) * kChunk);
    for (Index i = c * kChunk; i < end; ++i) values[i] = safe_value(f, X.row(i).transpose());
  });
  return values;
}

Index best_index(const Vec& values) {
  Index best = -1;
  double v = -std::numeric_limits<double>::infinity();
  for (Index i = 0; i < values.size(); ++i)
    if (values[i] > v) {
      v = values[i];
      best = i;
    }
  return best;
}

Mat default_starts(const RegionConstraint& region, Rng& rng) {
  const Mat seeds = feasible_rows(region, region.seeds());
  if (seeds.rows() > 0) return seeds;
  const Box& box = region.bounds();
  Vec x = 0.5 * (box.lower + box.upper);
  for (int tries = 0; tries < 1000 && region.has_constraint() && !region.contains(x); ++tries)
    x = box.lower + (rng.uniform_vec(box.dim()).array() * box.width().array()).matrix();
  return x.transpose();
}

Mat stack_rows(std::initializer_list<const Mat*> parts, Index cols) {
  Index rows = 0;
  for (const Mat* m : parts) rows += m->rows();
  Mat out(rows, cols);
  Index r = 0;
  for (const Mat* m : parts) {
    if (m->rows() == 0) continue;
    out.middleRows(r, m->rows()) = *m;
    r += m->rows();
  }
  return out;
}

void keep_better(OptimizeResult& best, OptimizeResult candidate) {
  const Index evaluations = best.evaluations + candidate.evaluations;
  const Index iterations = best.iterations + candidate.iterations;
  if (candidate.value > best.value || best.x.size() == 0) best = std::move(candidate);
  best.evaluations = evaluations;
  best.iterations = iterations;
}

}  // namespace varbo::nlopt_plugin
