#pragma once
// Test doubles shared by the acquisition tests (classic/, augmented_ei/): a surrogate whose Prediction is a given
// function of x, and a smooth predictive on [0,1]² whose every field (and derivative) depends on x.
#include <cmath>
#include <functional>
#include <utility>

#include "varbo/math.hpp"
#include "varbo/surrogate.hpp"

namespace varbo::acq::testing {

class FakeSurrogate final : public Surrogate {
 public:
  using Fn = std::function<Prediction(const Vec&, bool)>;
  explicit FakeSurrogate(Fn fn, double signal_variance = 1.0) : fn_(std::move(fn)), sv_(signal_variance) {}
  FitReport fit(const Dataset&, Rng&) override { return {}; }
  FitReport condition(const Dataset&) override { return {}; }
  Prediction predict(const Vec& x, bool with_gradient) const override { return fn_(x, with_gradient); }
  double signal_variance() const override { return sv_; }
  Hyperparameters hyperparameters() const override { return {}; }
  void set_hyperparameters(const Hyperparameters&) override {}
  bool ready() const override { return true; }

 private:
  Fn fn_;
  double sv_;
};

/// A smooth predictive on [0,1]²: every field depends on x, all derivatives nonzero.
inline Prediction smooth_prediction(const Vec& x, bool with_gradient, bool heteroscedastic) {
  const double x0 = x[0], x1 = x[1];
  Prediction p;
  p.mean = std::sin(3 * x0) + x1 * x1 - 0.5;
  p.latent_var = 0.05 + 0.04 * (1 + std::cos(2 * x0 + x1));
  p.log_noise_mean = -2 + 0.5 * std::sin(x0 + 2 * x1);
  p.log_noise_var = heteroscedastic ? 0.3 + 0.2 * x0 * x0 + 0.1 * x1 : 0.0;
  if (with_gradient) {
    p.d_mean = Vec{{3 * std::cos(3 * x0), 2 * x1}};
    const double s = std::sin(2 * x0 + x1);
    p.d_latent_var = Vec{{-0.08 * s, -0.04 * s}};
    const double c = std::cos(x0 + 2 * x1);
    p.d_log_noise_mean = Vec{{0.5 * c, 1.0 * c}};
    // A homoscedastic model has σ*² ≡ 0, hence a zero derivative.
    p.d_log_noise_var = heteroscedastic ? Vec{{0.4 * x0, 0.1}} : Vec(Vec::Zero(2));
  }
  return p;
}

/// Four evaluated points in [0,1]² (costs unused: the acquisitions read the model at them).
inline Dataset smooth_data() {
  Dataset d = Dataset::empty(2);
  for (const Vec& x : {Vec{{0.2, 0.3}}, Vec{{0.9, 0.1}}, Vec{{0.5, 0.8}}, Vec{{0.6, 0.5}}}) d.add(x, 0.0);
  return d;
}

}  // namespace varbo::acq::testing
