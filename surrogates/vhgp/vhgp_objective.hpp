#pragma once
// What the fit optimizer maximizes: the bound plus independent log-normal hyperpriors (Kuindersma 2013,
// eq. 13), over the packed vector [log Λ ; θ_f ; θ_g ; μ0] (or over log Λ alone, for a warm-up phase).
#include <cmath>
#include "varbo/function.hpp"
#include "varbo/math.hpp"
#include "vhgp_bound.hpp"

namespace varbo::vhgp {

/// log N(log ψ | m, s²) for every lengthscale and signal std of both kernels, and a normal prior on μ0 (the log
/// of the noise variance, i.e. a log-normal prior on the noise variance e^{μ0}). In model (standardized) units.
struct VhgpHyperprior {
  bool enabled = true;
  LogNormalPrior lengthscale_f{0.0, 1.6};  // 95% of the mass spans more than 20× the unit range (Kuindersma §3.4.1)
  LogNormalPrior signal_f{0.0, 1.0};
  LogNormalPrior lengthscale_g{0.0, 1.6};
  LogNormalPrior signal_g{0.0, 1.0};
  // Noise sd median 0.01·std(y), wide (the gp's prior): [log 0.1, 2] held the noise near 0.3·std(y) and cost
  // the noise-free and near-noise-free problems 2–4 decades of regret (docs/noisy.md, "vhgp defaults").
  LogNormalPrior mu0{2.0 * std::log(0.01), 6.0};
  /// Log density; adds its gradient to *grad (θ and μ0 parts) when non-null. 0 when disabled.
  double log_density(const VhgpParams& p, VhgpGradient* grad) const;
};

class VhgpObjective final : public DifferentiableFunction {
 public:
  /// Joint objective over all parameters.
  VhgpObjective(const VhgpBound& bound, const VhgpHyperprior& prior);
  /// Objective over log Λ only, the hyperparameters fixed at `fixed` (the authors' first phase, vhgp.md §8).
  VhgpObjective(const VhgpBound& bound, const VhgpHyperprior& prior, const VhgpParams& fixed);
  Index dim() const override;
  /// F + log prior; −∞ where the bound cannot be evaluated (the optimizers treat it as a failed step).
  double value(const Vec& x, Vec* grad) const override;
  VhgpParams params(const Vec& x) const;

 private:
  const VhgpBound& bound_;
  const VhgpHyperprior& prior_;
  bool lambda_only_ = false;
  VhgpParams fixed_;
};

/// The search box of the packed vector: wide bounds in log space (model units).
Box parameter_box(Index n, Index dim);

}  // namespace varbo::vhgp
