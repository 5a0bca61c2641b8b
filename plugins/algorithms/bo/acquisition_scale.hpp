#pragma once
// The acquisition as the optimizer sees it: multiplied by a positive factor so that the model's signal std is at
// least kMinSignalStd. The acquisitions (EI, PI·scale, CB, ERI) are in cost units, and the gradient-based polish
// (NLopt's L-BFGS, SLSQP) stops on absolute tolerances of the gradient (~1e-8): with costs of order 1e-8 it stopped
// at its start point, and the θ recommended on a bowl in those units lay 1e2–1e5× farther from the minimum (in
// squared distance) than in units of 1 (session 20; BOBYQA, without gradients, was unaffected). A positive factor
// changes no ordering of points, and at a signal std of kMinSignalStd or more it is 1: runs at such scales are
// unchanged, bit for bit.
#include <cmath>

#include "varbo/function.hpp"
#include "varbo/surrogate.hpp"

namespace varbo::bo {

inline constexpr double kMinSignalStd = 1e-3;

/// 1, or kMinSignalStd / σ_f when the model's signal std σ_f (cost units) is below kMinSignalStd.
inline double acquisition_scale(const Surrogate& model) {
  const double var = model.signal_variance();
  const double sd = std::isfinite(var) && var > 0 ? std::sqrt(var) : 0.0;
  return sd > 0 && sd < kMinSignalStd ? kMinSignalStd / sd : 1.0;
}

/// factor × f, with its gradient.
class ScaledFunction final : public DifferentiableFunction {
 public:
  ScaledFunction(const DifferentiableFunction& f, double factor) : f_(f), factor_(factor) {}
  Index dim() const override { return f_.dim(); }
  double value(const Vec& x, Vec* grad) const override {
    const double v = f_.value(x, grad);
    if (grad && grad->size()) *grad *= factor_;
    return factor_ * v;
  }
  bool has_gradient() const override { return f_.has_gradient(); }

 private:
  const DifferentiableFunction& f_;
  double factor_;
};

}  // namespace varbo::bo
