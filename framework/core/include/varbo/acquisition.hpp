#pragma once
// An acquisition: a utility to maximize over θ, built on a surrogate's Prediction.
#include <string>
#include "varbo/function.hpp"
#include "varbo/surrogate.hpp"

namespace varbo {

struct AcquisitionContext {
  const Surrogate* model = nullptr;
  const Dataset* data = nullptr;  ///< unit cube
  Index iteration = 0;
  Rng* rng = nullptr;  ///< for randomized acquisitions (a fresh stream per iteration)
};

/// Threads: prepare() is called from one thread; evaluate() from many threads at once (optimizers evaluate
/// candidates and polish starts in parallel), so it must only read what prepare() set.
class Acquisition {
 public:
  virtual ~Acquisition();
  /// Called once per iteration after the fit: finds the incumbent, draws random κ, ...
  virtual void prepare(const AcquisitionContext& context) = 0;
  /// Utility at x (unit cube), to be maximized; fills grad when non-null and has_gradient(). Thread-safe.
  virtual double evaluate(const Vec& x, Vec* grad) const = 0;
  virtual bool has_gradient() const { return true; }
  /// One line for logs (incumbent, κ, ...).
  virtual std::string state() const { return {}; }
};

/// Adapts a prepared acquisition to the Optimizer interface.
class AcquisitionFunction final : public DifferentiableFunction {
 public:
  AcquisitionFunction(const Acquisition& a, Index dim) : a_(a), dim_(dim) {}
  Index dim() const override { return dim_; }
  double value(const Vec& x, Vec* grad) const override { return a_.evaluate(x, grad); }
  bool has_gradient() const override { return a_.has_gradient(); }

 private:
  const Acquisition& a_;
  Index dim_;
};

/// The evaluated point minimizing E[y] + κ·s under the model (Kuindersma 2013, Alg. 2 and eq. 12):
/// μ_best is the lowest posterior mean at the data, not the lowest noisy observation.
struct Incumbent {
  Index index = -1;
  double mean = 0;
  double std = 0;
};
Incumbent find_incumbent(const Surrogate& model, const Dataset& data, double kappa = 0.0);

}  // namespace varbo
