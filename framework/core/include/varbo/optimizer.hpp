#pragma once
// Maximizes a function over a region from given starting points. Used for acquisitions (region = the
// acquisition region) and for hyperparameter fits (region = a box in log-parameter space).
#include <string>
#include "varbo/function.hpp"
#include "varbo/region.hpp"

namespace varbo {

struct OptimizeResult {
  Vec x;
  double value = -std::numeric_limits<double>::infinity();
  Index evaluations = 0;
  Index iterations = 0;
  bool success = false;
  std::string message;
};

/// Threads: maximize() may run on several threads at once on one instance (a surrogate's fit restarts share
/// its optimizer), and it may itself call f.value() from several threads: keep per-call state local.
class Optimizer {
 public:
  virtual ~Optimizer();
  /// Maximizes f over `region` starting from the rows of `starts` (may be empty: the optimizer picks).
  /// Must not throw on numerical trouble in f (NaN/inf values): it reports success = false instead.
  virtual OptimizeResult maximize(const DifferentiableFunction& f, const RegionConstraint& region,
                                  const Mat& starts, Rng& rng) const = 0;
};

/// A plain box region (used for hyperparameter fits and tests).
class BoxRegion final : public RegionConstraint {
 public:
  explicit BoxRegion(Box box) : box_(std::move(box)) {}
  const Box& bounds() const override { return box_; }

 private:
  Box box_;
};

}  // namespace varbo
