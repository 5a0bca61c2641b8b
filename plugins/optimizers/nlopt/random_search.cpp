#include <fmt/format.h>

#include "optimizers.hpp"
#include "search_support.hpp"

namespace varbo::nlopt_plugin {

OptimizeResult RandomSearchOptimizer::maximize(const DifferentiableFunction& f, const RegionConstraint& region,
                                               const Mat& starts, Rng& rng) const {
  const Box& box = region.bounds();
  const Index d = box.dim();
  // Points are drawn sequentially from rng (deterministic), then evaluated in parallel.
  Mat points(samples_, d);
  for (Index i = 0; i < samples_; ++i)
    points.row(i) = (box.lower.array() + rng.uniform_vec(d).array() * box.width().array()).transpose();
  const Mat feasible = feasible_rows(region, points);
  const Mat given = feasible_rows(region, starts);
  const Mat candidates = stack_rows({&feasible, &given}, d);
  const Vec values = evaluate_rows(f, candidates);
  OptimizeResult best;
  best.evaluations = candidates.rows();
  best.iterations = 1;
  const Index top = best_index(values);
  if (top >= 0) {
    best.x = candidates.row(top).transpose();
    best.value = values[top];
    best.success = true;
    best.message = fmt::format("best of {} feasible points", candidates.rows());
  } else {
    best.x = 0.5 * (box.lower + box.upper);
    best.message = fmt::format("no finite, feasible value among {} points", candidates.rows());
  }
  return best;
}

}  // namespace varbo::nlopt_plugin
