#pragma once
// The 1-D synthetic task of Kuindersma et al. 2013, section 5.1 / Fig. 2: two minima of equal expected
// cost with different cost variance. The paper shows it only as a picture; our explicit definition
// (README.md in this folder):
//   mean  m(θ) = 0.5 + 0.4·cos(4πθ),  θ ∈ [0, 1]   -> minima m = 0.1 at θ = 0.25 and θ = 0.75
//   std   s(θ) = 0.02 + 0.2·θ²                       -> s(0.25) = 0.0325 (low risk), s(0.75) = 0.1325
//   J(θ) = m(θ) + noise_scale·s(θ)·ε,  ε ~ N(0, 1)
#include "varbo/task.hpp"

namespace varbo::tasks {

double two_minima_mean(double theta);
double two_minima_std(double theta);

class TwoMinimaTask : public Task {
 public:
  explicit TwoMinimaTask(double noise_scale = 1.0) : noise_scale_(noise_scale) {}
  Domain domain() const override;
  Evaluation evaluate(const Vec& theta, Rng& rng) override;
  /// Minimum of the expected cost: 0.1 at both θ = 0.25 and θ = 0.75.
  std::optional<Optimum> optimum() const override;
  std::optional<double> noiseless_cost(const Vec& theta) const override {
    if (theta.size() != 1) return std::nullopt;
    return two_minima_mean(theta[0]);
  }

 private:
  double noise_scale_;
};

}  // namespace varbo::tasks
