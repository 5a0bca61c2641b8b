#pragma once
// A surrogate with a known closed form, for testing risk-sensitive selection without fitting anything:
// mean m(x) = 0.5 + 0.4·cos(4πx) (equal wells 0.1 at x = 1/4 and 3/4), noise std s(x) = 0.02 + 0.2·x²
// (the two_minima_1d task's definition, tasks/paper/README.md), no latent variance. Exact gradients.
#include <cmath>
#include <numbers>

#include "varbo/surrogate.hpp"

namespace varbo::test {

class FakeTwoWells final : public Surrogate {
 public:
  static double mean(double x) { return 0.5 + 0.4 * std::cos(4 * std::numbers::pi * x); }
  static double std_dev(double x) { return 0.02 + 0.2 * x * x; }
  FitReport fit(const Dataset&, Rng&) override { return {}; }
  FitReport condition(const Dataset&) override { return {}; }
  Prediction predict(const Vec& x, bool with_gradient) const override {
    const double t = x[0], s = std_dev(t);
    Prediction p;
    p.mean = mean(t);
    p.latent_var = 0;
    p.log_noise_mean = 2 * std::log(s);  // exp(g) = s², σ*² = 0 (homoscedastic form of the Prediction)
    p.log_noise_var = 0;
    if (with_gradient) {
      p.d_mean = Vec::Constant(1, -0.4 * 4 * std::numbers::pi * std::sin(4 * std::numbers::pi * t));
      p.d_latent_var = Vec::Zero(1);
      p.d_log_noise_mean = Vec::Constant(1, 2 * 0.4 * t / s);  // d(2 log s)/dx = 2 s'/s, s' = 0.4 x
      p.d_log_noise_var = Vec::Zero(1);
    }
    return p;
  }
  double signal_variance() const override { return 0.16; }
  Hyperparameters hyperparameters() const override { return {}; }
  void set_hyperparameters(const Hyperparameters&) override {}
  bool ready() const override { return true; }
};

}  // namespace varbo::test
