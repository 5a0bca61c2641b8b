#include <vector>

#include "optimizers.hpp"
#include "search_support.hpp"
#include "varbo/parallel.hpp"

namespace varbo::nlopt_plugin {

OptimizeResult NloptOptimizer::maximize(const DifferentiableFunction& f, const RegionConstraint& region,
                                        const Mat& starts, Rng& rng) const {
  Mat x0 = starts.rows() > 0 ? starts : default_starts(region, rng);
  // Infeasible starts are allowed: SLSQP, MMA and COBYLA move into the constraint on their own.
  std::vector<OptimizeResult> results(static_cast<std::size_t>(x0.rows()));
  parallel_for(x0.rows(), [&](Index k) {
    results[static_cast<std::size_t>(k)] = local_maximize(f, region, x0.row(k).transpose(), settings_);
  });
  OptimizeResult best;
  for (auto& r : results) keep_better(best, std::move(r));
  best.iterations = x0.rows();
  best.success = std::isfinite(best.value);
  if (!best.success) best.message = "no finite, feasible value found from " + std::to_string(x0.rows()) + " starts";
  return best;
}

}  // namespace varbo::nlopt_plugin
