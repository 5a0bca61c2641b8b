#pragma once
// Unconstrained L-BFGS line search (Ceres GradientProblemSolver) behind the Optimizer interface.
// Used by default for GP hyperparameter fits over log-parameters, where the box is only advisory.
#include "varbo/optimizer.hpp"

namespace varbo::ceres_lbfgs {

struct LbfgsSettings {
  int max_iterations = 200;
  double function_tolerance = 1e-6;   ///< Ceres: stop when |Δf| / |f| falls below this
  double gradient_tolerance = 1e-10;  ///< Ceres: stop when max |x − P(x − g)| falls below this
  double parameter_tolerance = 1e-8;  ///< Ceres: stop when |Δx| / (|x| + tol) falls below this
  /// Converged only when also max_i |∂f/∂x_i| ≤ this · max(1, |f|): a Ceres stop on the function or parameter
  /// tolerance with a larger gradient restarts L-BFGS from there (within max_iterations). Ceres' relative
  /// function rule alone stopped VHGP fits on 133 points well short of the optimum (bench/fit_convergence).
  double relative_gradient_tolerance = 1e-4;
  int lbfgs_rank = 20;                ///< number of correction pairs kept
};

/// Maximizes f = minimizes −f from each row of `starts` in turn and keeps the best. The region's box is
/// ignored (only used to pick a start when none is given) and its constraint cannot be honoured.
/// Without an analytic gradient, central finite differences stand in. A start ends when Ceres stops and the
/// gradient is small (relative_gradient_tolerance), or the iterations are spent, or a restart stalls.
class CeresLbfgs final : public Optimizer {
 public:
  explicit CeresLbfgs(LbfgsSettings settings = {}) : settings_(settings) {}
  OptimizeResult maximize(const DifferentiableFunction& f, const RegionConstraint& region, const Mat& starts,
                          Rng& rng) const override;
  const LbfgsSettings& settings() const { return settings_; }

 private:
  OptimizeResult run_from(const DifferentiableFunction& f, const Vec& start) const;
  LbfgsSettings settings_;
};

}  // namespace varbo::ceres_lbfgs
