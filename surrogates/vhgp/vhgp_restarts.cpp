#include "vhgp_restarts.hpp"

#include <algorithm>
#include <optional>

#include "budgeted_objective.hpp"
#include "varbo/errors.hpp"
#include "varbo/log.hpp"
#include "varbo/restarts.hpp"

namespace varbo::vhgp {

Vec maximize_log_lambda(const VhgpObjective& joint, const VhgpParams& fixed, const Box& box, const Optimizer& optimizer,
                        Rng& rng) {
  const Index n = fixed.log_lambda.size();
  const VhgpObjective lambda_objective(joint.bound(), joint.prior(), fixed);
  const BoxRegion lambda_region(Box{box.lower.head(n), box.upper.head(n)});
  try {
    const OptimizeResult w = optimizer.maximize(lambda_objective, lambda_region, fixed.log_lambda.transpose(), rng);
    if (w.x.size() == n && w.x.allFinite() && std::isfinite(lambda_objective.value(w.x, nullptr)))
      return lambda_region.bounds().clamp(w.x);
  } catch (const PluginCodeError&) {
    throw;  // a component's code is wrong (a kernel's result of the wrong size): no fit is usable
  } catch (const std::exception& e) {
    log_debug("vhgp: log Lambda optimization failed: {}", e.what());
  }
  return fixed.log_lambda;
}

std::vector<RestartResult> optimize_restarts(const VhgpObjective& objective, const BoxRegion& region,
                                             const std::vector<VhgpParams>& starts, const Optimizer& optimizer,
                                             const Rng& base, const RestartSettings& settings) {
  const Box& box = region.bounds();
  // Most restarts of a fit end in the same optimum, so spending 60–200 evaluations on each was the bulk of the
  // fit time (README, benchmark): hence the two stages.
  const Index n_final = std::min<Index>(std::max(settings.finalists, 1), static_cast<Index>(starts.size()));
  const bool staged = settings.restart_evaluations > 0 && static_cast<Index>(starts.size()) > n_final;
  // A lone start is a warm-only fit between full fits (`warm_evaluations`): the previous optimum moved by one
  // point, improved within a budget rather than to convergence.
  const bool lone_budgeted = starts.size() == 1 && settings.single_start_evaluations > 0;
  RestartSettings budget = settings;
  if (lone_budgeted) budget.restart_evaluations = settings.single_start_evaluations;
  auto optimize = [&](const Vec& start, Rng& r, bool budgeted, Index k, RestartResult& out) {
    try {
      Vec x0 = box.clamp(start);
      if (settings.lambda_warmup && !out.ok) {
        // Phase 1: log Λ alone, hyperparameters fixed (the authors' fixhyp = 2 phase).
        const VhgpParams fixed = objective.bound().unpack(x0);
        x0.head(fixed.log_lambda.size()) = maximize_log_lambda(objective, fixed, box, optimizer, r);
      }
      Vec x;
      if (budgeted) {
        const BudgetedObjective limited(objective, budget.restart_evaluations);
        const OptimizeResult res = optimizer.maximize(limited, region, x0.transpose(), r);
        x = limited.best_x();
        log_debug("vhgp: restart {} (stage 1): objective {:.10g} after {} iterations: {}", k, limited.best_value(),
                  res.iterations, res.message);
      } else {
        const OptimizeResult res = optimizer.maximize(objective, region, x0.transpose(), r);
        x = res.x;
        log_debug("vhgp: restart {}: {} iterations ({} evaluations): {}", k, res.iterations, res.evaluations,
                  res.message);
      }
      if (x.size() == objective.dim() && x.allFinite()) {
        // Re-evaluate: the reported value must be the objective at the returned point.
        const double v = objective.value(x, nullptr);
        log_debug("vhgp: restart {}: objective {:.10g}", k, v);
        // A converged restart that ended below its stage-1 point keeps the better one.
        if (std::isfinite(v) && (!out.ok || v >= out.objective)) {
          out.ok = true;
          out.objective = v;
          out.x = x;
        }
      }
    } catch (const PluginCodeError&) {
      throw;
    } catch (const std::exception& e) {
      log_debug("vhgp: restart {} failed: {}", k, e.what());
    }
  };

  // Stage 1 (or the only stage): start k on stream (2, k); stage 2 continues finalist k on stream (3, k).
  const auto score = [](const RestartResult& r) { return r.ok ? std::optional<double>(r.objective) : std::nullopt; };
  std::vector<RestartResult> results =
      run_restarts<RestartResult>(
          static_cast<Index>(starts.size()), [&](Index k) { return base.stream(2, static_cast<std::uint64_t>(k)); },
          [&](Index k, Rng& r) {
            RestartResult out;
            optimize(starts[static_cast<std::size_t>(k)].pack(), r, staged || lone_budgeted, k, out);
            return out;
          },
          score)
          .results;
  if (!staged) return results;
  // The finalists in order of their stage-1 objective (ties: lower index), independent of the thread count.
  std::vector<Index> order;
  for (Index k = 0; k < static_cast<Index>(results.size()); ++k)
    if (results[static_cast<std::size_t>(k)].ok) order.push_back(k);
  std::stable_sort(order.begin(), order.end(), [&](Index a, Index b) {
    return results[static_cast<std::size_t>(a)].objective > results[static_cast<std::size_t>(b)].objective;
  });
  order.resize(std::min<std::size_t>(order.size(), static_cast<std::size_t>(n_final)));
  const auto finalist = [&](Index j) { return order[static_cast<std::size_t>(j)]; };
  const Restarts<RestartResult> final_run = run_restarts<RestartResult>(
      static_cast<Index>(order.size()), [&](Index j) { return base.stream(3, static_cast<std::uint64_t>(finalist(j))); },
      [&](Index j, Rng& r) {
        RestartResult out = results[static_cast<std::size_t>(finalist(j))];  // keeps its stage-1 point if better
        optimize(out.x, r, false, finalist(j), out);
        return out;
      },
      score);
  for (std::size_t j = 0; j < order.size(); ++j) results[static_cast<std::size_t>(order[j])] = final_run.results[j];
  return results;
}

}  // namespace varbo::vhgp
