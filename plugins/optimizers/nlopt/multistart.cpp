#include <fmt/format.h>

#include <algorithm>
#include <mutex>
#include <numeric>
#include <optional>
#include <vector>

#include "optimizers.hpp"
#include "search_support.hpp"
#include "unit_designs.hpp"
#include "varbo/log.hpp"
#include "varbo/restarts.hpp"

namespace varbo::nlopt_plugin {

OptimizeResult MultistartOptimizer::maximize(const DifferentiableFunction& f, const RegionConstraint& region,
                                             const Mat& starts, Rng& rng) const {
  const Box& box = region.bounds();
  const Index d = box.dim();
  // One draw from the caller's stream names this call; every random part derives its own stream from it.
  const std::uint64_t call = rng.next();

  // 1. Candidates: scrambled Sobol points in the box, then the region's seeds and the caller's starts. Beyond the
  // Sobol sequence's dimensions, uniform points: a run of 4000 parameters stopped after its design with "sobol:
  // dimension 4000 is outside the supported range" (audit, session 45).
  Rng sobol_rng = rng.stream(call, 0);
  Mat unit;
  if (d <= sampling::kSobolMaxDim) {
    sampling::SobolSequence sobol(d, /*scramble=*/true, sobol_rng);
    unit = sobol.next(settings_.candidates);
  } else {
    static std::once_flag said;  // once per process, not per acquisition search
    std::call_once(said, [d] {
      log_info("multistart: {} dimensions, more than the Sobol sequence's {}: uniform candidates", d,
               sampling::kSobolMaxDim);
    });
    unit = sampling::uniform_unit(settings_.candidates, d, sobol_rng);
  }
  Mat in_box(unit.rows(), d);
  for (Index i = 0; i < unit.rows(); ++i)
    in_box.row(i) = (box.lower.array() + unit.row(i).transpose().array() * box.width().array()).transpose();
  const Mat sobol_points = feasible_rows(region, in_box);
  const Mat seeds = feasible_rows(region, region.seeds());
  const Mat given = feasible_rows(region, starts);
  const Mat candidates = stack_rows({&sobol_points, &seeds, &given}, d);

  // 2. Values without gradients, in parallel chunks.
  const Vec values = evaluate_rows(f, candidates);
  OptimizeResult best;
  best.evaluations = candidates.rows();
  const Index top = best_index(values);
  if (top >= 0) {
    best.x = candidates.row(top).transpose();
    best.value = values[top];
  }

  // 3. Polish the best few, ordered by value (index order on ties).
  std::vector<Index> order(static_cast<std::size_t>(candidates.rows()));
  std::iota(order.begin(), order.end(), Index{0});
  std::stable_sort(order.begin(), order.end(), [&](Index a, Index b) { return values[a] > values[b]; });
  std::vector<Index> chosen;
  for (Index i : order) {
    if (static_cast<Index>(chosen.size()) >= settings_.polish || !std::isfinite(values[i])) break;
    chosen.push_back(i);
  }
  // Restart k has its own stream (unused by the deterministic local methods, kept for stochastic ones).
  const Restarts<OptimizeResult> polished = run_restarts<OptimizeResult>(
      static_cast<Index>(chosen.size()), [&](Index k) { return rng.stream(call, static_cast<std::uint64_t>(k) + 1); },
      [&](Index k, Rng&) {
        return local_maximize(f, region, candidates.row(chosen[static_cast<std::size_t>(k)]).transpose(),
                              settings_.local);
      },
      [](const OptimizeResult& r) { return std::isnan(r.value) ? std::nullopt : std::optional<double>(r.value); });
  // The best polished point replaces the best candidate only when strictly better; evaluations add up.
  Index polish_evaluations = 0;
  for (const OptimizeResult& r : polished.results) polish_evaluations += r.evaluations;
  if (polished.best >= 0 && polished.results[static_cast<std::size_t>(polished.best)].value > best.value)
    best = polished.results[static_cast<std::size_t>(polished.best)];
  best.evaluations = candidates.rows() + polish_evaluations;
  best.iterations = static_cast<Index>(chosen.size());
  best.success = std::isfinite(best.value);
  best.message = best.success ? fmt::format("{} candidates ({} feasible Sobol), {} polished", candidates.rows(),
                                            sobol_points.rows(), chosen.size())
                              : "no finite, feasible value among the candidates";
  if (best.x.size() == 0) best.x = 0.5 * (box.lower + box.upper);
  if (sobol_points.rows() == 0 && region.has_constraint())
    log_warn("multistart: none of {} Sobol candidates lies inside the region's constraint", settings_.candidates);
  return best;
}

}  // namespace varbo::nlopt_plugin
