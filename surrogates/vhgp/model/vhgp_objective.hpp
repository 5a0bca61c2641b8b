#pragma once
// What the fit optimizer maximizes: the bound plus independent log-normal hyperpriors (Kuindersma 2013,
// eq. 13), over the packed vector [log Λ ; θ_f ; θ_g ; μ0] (or over log Λ alone, for a warm-up phase).
#include <cmath>
#include <memory>
#include "varbo/function.hpp"
#include "varbo/math.hpp"
#include "vhgp_bound.hpp"

namespace varbo::vhgp {

/// The hyperpriors and fit boxes of the VHGP, by role (varbo::KernelParameterRole), in model (standardized)
/// units: every lengthscale of k_f gets `lengthscale_f`, every amplitude `signal_f`, likewise for k_g; noise
/// (white) and shape parameters keep their kernel's own prior and box. μ0, the log of the noise variance, gets a
/// normal prior (a log-normal prior on the noise variance e^{μ0}).
struct VhgpHyperprior {
  bool enabled = true;
  LogNormalPrior lengthscale_f{0.0, 1.6};  // 95% of the mass spans more than 20× the unit range (Kuindersma §3.4.1)
  LogNormalPrior signal_f{0.0, 1.0};
  LogNormalPrior lengthscale_g{0.0, 1.6};
  LogNormalPrior signal_g{0.0, 1.0};
  // Noise sd median 0.01·std(y), wide (the gp's prior): [log 0.1, 2] held the noise near 0.3·std(y) and cost
  // the noise-free and near-noise-free problems 2–4 decades of regret (docs/noisy.md, "vhgp defaults").
  LogNormalPrior mu0{2.0 * std::log(0.01), 6.0};

  /// A copy of `form` with these priors and the VHGP's boxes on its roles. Boxes (natural, model units):
  /// lengthscales [1e-3, 1e3] (unit cube); amplitudes of f [1e-3, 1e2] (standardized costs), of g [1e-4, 30]
  /// (std of the log noise variance; the lower end is the constant-noise member of the model).
  std::unique_ptr<Kernel> configured(const Kernel& form, Process process) const;
};

/// The box of μ0 (model units).
constexpr double kMu0Lower = -30.0, kMu0Upper = 8.0;

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
  /// The hyperprior term at p (0 when disabled); adds its gradient to *grad (θ and μ0 parts) when non-null.
  double log_prior(const VhgpParams& p, VhgpGradient* grad) const;
  /// The search box of the packed joint vector, in log space (model units): log Λ in [−15, 12], each kernel's
  /// box from `configured`, μ0 in [kMu0Lower, kMu0Upper].
  Box box() const;
  const VhgpBound& bound() const { return bound_; }
  const VhgpHyperprior& prior() const { return prior_; }
  /// The kernels with the priors and boxes of the objective.
  const Kernel& f_form() const { return *f_; }
  const Kernel& g_form() const { return *g_; }

 private:
  const VhgpBound& bound_;
  const VhgpHyperprior& prior_;
  std::shared_ptr<const Kernel> f_, g_;
  bool lambda_only_ = false;
  VhgpParams fixed_;
};

}  // namespace varbo::vhgp
