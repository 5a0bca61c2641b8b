#pragma once
// A Task wrapping one benchmark function: a box domain, optional additive Gaussian noise, known optimum.
#include <optional>

#include "benchmark_functions.hpp"
#include "failure_region.hpp"
#include "varbo/task.hpp"

namespace varbo::tasks {

class BenchmarkTask : public Task {
 public:
  /// `box` must have `dim` dimensions; `noise_std` >= 0 is the std of the additive N(0, σ²) noise.
  BenchmarkTask(const BenchmarkSpec& spec, Index dim, Box box, double noise_std);

  Domain domain() const override;
  /// cost = f(θ) + noise_std·ε, ε ~ N(0, 1) drawn from the trial's stream. No components.
  Evaluation evaluate(const Vec& theta, Rng& rng) override;
  /// The known minimum; minimizers outside a user-given box are dropped, and when none is left the
  /// optimum is unknown (nullopt), because f* would no longer be the minimum over the domain.
  std::optional<Optimum> optimum() const override;

  /// Trials with θ inside `region` (fractions of the box) fail; nullopt = none.
  void set_failure_region(std::optional<FailureRegion> region) { failure_region_ = std::move(region); }

  /// The noiseless value.
  double value(const Vec& theta) const { return spec_.f(theta); }
  std::optional<double> noiseless_cost(const Vec& theta) const override {
    if (theta.size() != dim_) return std::nullopt;
    return spec_.f(theta);
  }

 private:
  const BenchmarkSpec& spec_;
  Index dim_;
  Box box_;
  double noise_std_;
  std::optional<FailureRegion> failure_region_;
};

}  // namespace varbo::tasks
