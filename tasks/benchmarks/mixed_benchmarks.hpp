#pragma once
// Benchmarks on typed search spaces (docs/search_space.md): each is a function of θ in user units (one value per
// parameter, a category as its index) over a SearchSpace with its own integer, categorical, log-scaled parameters
// or linear constraints, with a known minimum.
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "varbo/search_space.hpp"
#include "varbo/task.hpp"

namespace varbo::tasks {

struct MixedBenchmark {
  std::string name;
  std::string description;
  SharedSpace space;
  std::function<double(const Vec&)> f;  ///< θ in user units
  double f_min = 0;
  Vec argmin;                           ///< θ* in user units
};

/// mixed_ackley, integer_rosenbrock, log_scale, branin_constrained.
const std::vector<MixedBenchmark>& mixed_benchmarks();

class MixedBenchmarkTask : public Task, public SpaceAware {
 public:
  MixedBenchmarkTask(const MixedBenchmark& b, double noise_std) : b_(b), noise_std_(noise_std) {}
  Domain domain() const override { return Domain{b_.space->user_box(), b_.space->names()}; }
  SharedSpace search_space() const override { return b_.space; }
  /// Its parameters are its own (the study refuses `parameters:` for it).
  void set_search_space(SharedSpace) override { throw std::logic_error("a benchmark's parameters are fixed"); }
  Evaluation evaluate(const Vec& theta, Rng& rng) override;
  std::optional<Optimum> optimum() const override { return Optimum{b_.f_min, {b_.argmin}}; }
  std::optional<double> noiseless_cost(const Vec& theta) const override;

 private:
  const MixedBenchmark& b_;
  double noise_std_;
};

}  // namespace varbo::tasks
