#pragma once
// A Task: one noisy-suite function at (dimension, instance) observed through one noise model at one level.
#include <string>

#include "noise_models.hpp"
#include "noisy_functions.hpp"
#include "varbo/task.hpp"

namespace varbo::tasks::noisy {

class NoisyTask : public Task {
 public:
  /// Throws std::invalid_argument when `dim` does not suit the function or `instance` < 1.
  NoisyTask(const NoisyFunctionSpec& spec, Index dim, long instance, Noise noise);

  Domain domain() const override;
  /// cost = f* + noise.apply(f(θ) - f*); Evaluation::noiseless_cost = f(θ). Noise draws come from `rng` only.
  Evaluation evaluate(const Vec& theta, Rng& rng) override;
  /// f* and every global minimizer.
  std::optional<Optimum> optimum() const override;
  /// f(θ), not counted as a trial (nullopt for a θ of the wrong size).
  std::optional<double> noiseless_cost(const Vec& theta) const override;

  const FunctionInstance& function() const { return fn_; }
  const Noise& noise() const { return noise_; }
  /// "rosenbrock d=5 instance 2, multiplicative severe: g exp(1 N)".
  std::string describe() const;

 private:
  const NoisyFunctionSpec& spec_;
  Index dim_;
  long instance_;
  FunctionInstance fn_;
  Noise noise_;
};

}  // namespace varbo::tasks::noisy
