#pragma once
// The optimizers of libvarbo_nlopt.so: a local NLopt method from given starts, a multi-start search
// (quasi-random candidates, then local polish of the best few) and plain random search.
#include "local_search.hpp"
#include "varbo/optimizer.hpp"

namespace varbo::nlopt_plugin {

/// The `nlopt` component's settings: a stand-alone local run gets a fixed method, more evaluations and tighter
/// tolerances than a multistart polish (LocalSettings' own defaults).
struct NloptSettings {
  LocalSettings local{LocalMethod::Slsqp, 500, 1e-8, 1e-10};
};

/// Runs a local NLopt method from every start row (in parallel) and keeps the best feasible result.
class NloptOptimizer final : public Optimizer {
 public:
  explicit NloptOptimizer(LocalSettings settings) : settings_(settings) {}
  OptimizeResult maximize(const DifferentiableFunction& f, const RegionConstraint& region, const Mat& starts,
                          Rng& rng) const override;

 private:
  LocalSettings settings_;
};

struct MultistartSettings {
  Index candidates = 2000;  ///< scrambled Sobol points in the box (those outside the region are dropped)
  Index polish = 10;        ///< best candidates refined by the local method
  LocalSettings local;
};

/// Evaluates Sobol candidates plus the region's seeds and the given starts without gradients, then polishes
/// the best `polish` of them with a local NLopt method in parallel (one Rng stream per start, reduced in
/// index order: the result does not depend on the thread count).
class MultistartOptimizer final : public Optimizer {
 public:
  explicit MultistartOptimizer(MultistartSettings settings) : settings_(settings) {}
  OptimizeResult maximize(const DifferentiableFunction& f, const RegionConstraint& region, const Mat& starts,
                          Rng& rng) const override;

 private:
  MultistartSettings settings_;
};

struct RandomSearchSettings {
  Index samples = 2000;  ///< uniform points drawn in the box
};

/// Uniform points in the box (plus the given starts); keeps the best feasible one.
class RandomSearchOptimizer final : public Optimizer {
 public:
  explicit RandomSearchOptimizer(Index samples) : samples_(samples) {}
  OptimizeResult maximize(const DifferentiableFunction& f, const RegionConstraint& region, const Mat& starts,
                          Rng& rng) const override;

 private:
  Index samples_;
};

}  // namespace varbo::nlopt_plugin
