#pragma once
// An evaluation budget around any objective, for the first stage of the VHGP restarts: every start gets a
// few dozen evaluations, and only the most promising ones are then optimized to convergence (README, "Fit").
// It works with any fit optimizer: once the budget is spent the wrapper reports the best value seen with a
// zero gradient, so gradient-based and derivative-free optimizers alike stop within an iteration or two,
// and the caller takes the recorded best point rather than the optimizer's last iterate.
#include <cmath>
#include <limits>
#include <mutex>

#include "varbo/function.hpp"

namespace varbo::vhgp {

class BudgetedObjective final : public DifferentiableFunction {
 public:
  BudgetedObjective(const DifferentiableFunction& inner, int budget) : inner_(inner), budget_(budget) {}
  Index dim() const override { return inner_.dim(); }
  bool has_gradient() const override { return inner_.has_gradient(); }

  double value(const Vec& x, Vec* grad) const override {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (used_ >= budget_ && best_x_.size() > 0) {
        if (grad) *grad = Vec::Zero(dim());
        return best_value_;
      }
      ++used_;
    }
    const double v = inner_.value(x, grad);
    std::lock_guard<std::mutex> lock(mutex_);
    if (std::isfinite(v) && (best_x_.size() == 0 || v > best_value_)) {
      best_value_ = v;
      best_x_ = x;
    }
    return v;
  }

  /// The best point evaluated (empty if no evaluation was finite) and its value.
  const Vec& best_x() const { return best_x_; }
  double best_value() const { return best_value_; }

 private:
  const DifferentiableFunction& inner_;
  int budget_;
  mutable std::mutex mutex_;
  mutable int used_ = 0;
  mutable double best_value_ = -std::numeric_limits<double>::infinity();
  mutable Vec best_x_;
};

}  // namespace varbo::vhgp
