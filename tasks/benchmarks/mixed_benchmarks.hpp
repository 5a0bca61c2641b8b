#pragma once
// Benchmarks on typed search spaces (docs/search_space.md): each is a function of θ in user units (one value per
// parameter, a category as its index) over a SearchSpace with its own integer, categorical, log-scaled parameters
// or linear constraints, with a known minimum.
#include <functional>
#include <memory>
#include <mutex>
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
  /// Its minimum (f*, θ* in user units). Some are found numerically, by a dense scan of ~0.1 s CPU: that runs
  /// the first time the minimum is asked for, not when the plugin registers — which every process loading the
  /// plugin would pay (`varbo suggest` on any benchmark study, docs/studies.md).
  std::function<Optimum()> locate_minimum;
  const Optimum& minimum() const;

  struct Located {
    std::once_flag once;
    Optimum value;
  };
  std::shared_ptr<Located> located = std::make_shared<Located>();
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
  std::optional<Optimum> optimum() const override { return b_.minimum(); }
  std::optional<double> noiseless_cost(const Vec& theta) const override;

 private:
  const MixedBenchmark& b_;
  double noise_std_;
};

}  // namespace varbo::tasks
