#pragma once
// A scalar function with an optional analytic gradient, and a finite-difference check for it.
#include <functional>
#include "varbo/types.hpp"

namespace varbo {

/// Threads: value() is const and may be called from several threads at once.
class DifferentiableFunction {
 public:
  virtual ~DifferentiableFunction();
  virtual Index dim() const = 0;
  /// Value at x; if grad is non-null and has_gradient(), fills the gradient (resized by the callee).
  virtual double value(const Vec& x, Vec* grad) const = 0;
  virtual bool has_gradient() const { return true; }
};

/// Wraps a callable `double(const Vec&, Vec*)`.
class FunctionRef final : public DifferentiableFunction {
 public:
  using Fn = std::function<double(const Vec&, Vec*)>;
  FunctionRef(Index dim, Fn fn, bool has_gradient = true)
      : dim_(dim), fn_(std::move(fn)), has_gradient_(has_gradient) {}
  Index dim() const override { return dim_; }
  double value(const Vec& x, Vec* grad) const override { return fn_(x, has_gradient_ ? grad : nullptr); }
  bool has_gradient() const override { return has_gradient_; }

 private:
  Index dim_;
  Fn fn_;
  bool has_gradient_;
};

struct GradientCheck {
  Vec analytic;
  Vec numeric;
  double max_abs_error = 0;
  double max_rel_error = 0;  ///< |a - n| / max(|a|, |n|, floor)
};

/// Central differences with step h (relative to max(1, |x_i|)); used by the tests of every analytic gradient.
GradientCheck check_gradient(const DifferentiableFunction& f, const Vec& x, double h = 1e-6,
                             double floor = 1e-8);

}  // namespace varbo
