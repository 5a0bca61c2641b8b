#pragma once
// Synthetic objective of Fröhlich et al. 2021, section 5.1: a sample of a zero-mean GP with a Matérn-5/2
// kernel (σ_f² = 1, ℓ = 0.3) on [−1, 1]^d, conditioned on f(0) = 3 at the centre. The sample is made an
// explicit deterministic function of θ with random Fourier features (Rahimi & Recht 2007) and conditioned by
// pathwise (Matheron) correction (Wilson et al. 2020):
//   f(θ) = f_prior(θ) + k(θ, 0)/k(0, 0) · (3 − f_prior(0)),
// which is exactly a posterior sample given a noise-free observation y = 3 at 0 (up to the RFF approximation
// of the prior). The paper MAXIMIZES f (regret |y_t − y*| with y* the maximum near the conditioned peak);
// varbo minimizes costs, so the task's cost is −f(θ) + noise.
#include <cstdint>

#include "varbo/task.hpp"

namespace varbo::tasks {

struct GpSampleSettings {
  Index dim = 2;
  std::uint64_t seed = 0;
  Index features = 1000;     ///< random Fourier features
  double lengthscale = 0.3;  ///< ℓ in user units (the domain is [−1, 1]^d)
  double signal_var = 1.0;   ///< σ_f²
  double center_value = 3.0; ///< conditioning value at the centre (paper: y = 3)
  double noise_std = 1e-3;   ///< observation noise (paper: σ = 10⁻³)
  double start_distance = 0.3;  ///< distance of the initial point from the optimum (paper: 0.3)
  Index search_points = 0;   ///< dense-search points for the optimum; 0 = 20000·d
};

/// Matérn-5/2 correlation at distance r for lengthscale ℓ, and its derivative d/dr.
double matern52(double r, double ell);
double matern52_dr(double r, double ell);

/// The explicit sample function f (to be maximized), with gradient.
class GpSampleFunction {
 public:
  explicit GpSampleFunction(const GpSampleSettings& s);
  double value(const Vec& theta, Vec* grad = nullptr) const;
  double prior_value(const Vec& theta) const;  ///< the unconditioned RFF sample
  Index dim() const { return omega_.cols(); }

 private:
  Mat omega_;  ///< features × d frequencies
  Vec phase_;  ///< features
  Vec weight_; ///< features, N(0, 1)
  double scale_ = 0;  ///< sqrt(2σ_f²/M)
  double ell_ = 0.3;
  double signal_var_ = 1;
  double correction_ = 0;  ///< (y0 − f_prior(0))/σ_f²
};

class GpSampleTask final : public Task {
 public:
  explicit GpSampleTask(const GpSampleSettings& s);
  Domain domain() const override;
  Evaluation evaluate(const Vec& theta, Rng& rng) override;
  std::optional<Optimum> optimum() const override { return optimum_; }
  std::optional<Vec> initial_point() const override { return initial_; }
  const GpSampleFunction& function() const { return f_; }
  std::optional<double> noiseless_cost(const Vec& theta) const override {
    if (theta.size() != s_.dim) return std::nullopt;
    return -f_.value(theta);
  }

 private:
  GpSampleSettings s_;
  GpSampleFunction f_;
  Optimum optimum_;
  Vec initial_;
};

}  // namespace varbo::tasks
