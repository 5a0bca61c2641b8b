#pragma once
// The restarts of a VHGP fit (README, "Fit"): every start gets a budget of evaluations, the best few are then
// optimized to convergence, all through the one restart routine (varbo/restarts.hpp) with one random stream per
// start, so the result does not depend on the thread count.
#include <vector>

#include "varbo/optimizer.hpp"
#include "vhgp_objective.hpp"

namespace varbo::vhgp {

/// One restart's outcome, written only by its own task (deterministic reduction in index order).
struct RestartResult {
  bool ok = false;
  double objective = -std::numeric_limits<double>::infinity();
  Vec x;  ///< packed parameters (VhgpParams::pack)
};

struct RestartSettings {
  int restart_evaluations = 40;  ///< stage-1 evaluations per start; 0: every start runs to convergence
  int finalists = 2;             ///< starts optimized to convergence after stage 1
  bool lambda_warmup = false;    ///< log Λ alone first (the authors' fixhyp = 2 phase)
  int single_start_evaluations = 0;  ///< a lone start (a warm-only fit) stops after this many; 0: to convergence
};

/// Maximizes `objective` over `region` from every start. Stage 1: each start gets `restart_evaluations`
/// evaluations (all run to convergence when 0 or when there are no more starts than finalists); stage 2: the
/// `finalists` best of stage 1 are optimized to convergence. Start k runs on stream (2, k) of `base`, finalist k
/// continues on stream (3, k). Results in the order of `starts`.
std::vector<RestartResult> optimize_restarts(const VhgpObjective& objective, const BoxRegion& region,
                                             const std::vector<VhgpParams>& starts, const Optimizer& optimizer,
                                             const Rng& base, const RestartSettings& settings);

/// log Λ maximizing the objective at the hyperparameters of `fixed` (its log Λ the start), within `box` (the joint
/// box; its first n entries bound log Λ); `fixed.log_lambda` when the optimizer fails.
Vec maximize_log_lambda(const VhgpObjective& joint, const VhgpParams& fixed, const Box& box, const Optimizer& optimizer,
                        Rng& rng);

}  // namespace varbo::vhgp
