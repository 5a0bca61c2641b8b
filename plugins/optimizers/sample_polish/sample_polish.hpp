#pragma once
// Acquisition optimizer of CRBO (Fröhlich et al. 2021, section 4; crbo.md "local polish"): evaluate f on samples
// of the region (hit-and-run by default), then polish the best few with constrained SQP (NLopt SLSQP, or COBYLA
// when f has no gradient) inside a small box around each, honouring the region's constraint c(θ) ≥ 0.
#include <memory>

#include "varbo/optimizer.hpp"
#include "varbo/sampler.hpp"
#include "varbo/state.hpp"

namespace varbo {

struct SamplePolishOptions {
  Index samples = 1000;          ///< crbo.md: 1000 samples
  Index polish = 3;              ///< local searches from the best samples
  double polish_halfwidth = 0.1; ///< half-width of the polish box (unit cube); crbo.md uses ±0.5 lengthscales
  int max_iterations = 100;      ///< crbo.md
  double tolerance = 1e-4;       ///< relative x and f tolerance of the local search, crbo.md
};

class SamplePolishOptimizer final : public Optimizer, public ComponentState {
 public:
  SamplePolishOptimizer(std::unique_ptr<Sampler> sampler, SamplePolishOptions options);
  /// The feasible rows of `starts` are evaluated along with the samples. The result is the best point found
  /// that region.contains(); success = false only if no finite value at a feasible point was found.
  OptimizeResult maximize(const DifferentiableFunction& f, const RegionConstraint& region, const Mat& starts,
                          Rng& rng) const override;
  /// The sampler's state (hit-and-run chains), if it has one.
  std::string save_state() const override;
  void restore_state(const std::string& state) override;

 private:
  std::unique_ptr<Sampler> sampler_;
  SamplePolishOptions options_;
};

}  // namespace varbo
