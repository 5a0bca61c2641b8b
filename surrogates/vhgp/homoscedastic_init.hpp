#pragma once
// A quick homoscedastic GP fit used to initialize the VHGP: the authors' driver first fits
// y ~ GP(0, k_f + σ_n² δ) and starts the VHGP from its k_f hyperparameters and noise level (vhgp.md, section 8).
#include "varbo/optimizer.hpp"
#include "vhgp_objective.hpp"

namespace varbo::vhgp {

struct HomoscedasticFit {
  bool ok = false;
  Vec theta_f;               ///< log-parameters of k_f
  double log_noise_var = 0;  ///< log σ_n²
  double log_likelihood = 0;
};

/// log N(y | 0, K_f + σ_n² I) (K_f with the relative jitter) and its gradient over [θ_f ; log σ_n]
/// (Rasmussen & Williams eq. 5.8–5.9). `kernel` gives the form; its own values are not used.
double homoscedastic_log_likelihood(const Mat& X, const Vec& y, const Kernel& kernel, double jitter, const Vec& x,
                                    Vec* grad);

/// [θ_f ; log σ_n] of a fit, the optimizer's coordinates (a warm start for the next fit).
Vec homoscedastic_coordinates(const HomoscedasticFit& fit);

/// Maximizes the homoscedastic likelihood (+ the f and μ0 hyperpriors when enabled) over the box of `kernel`
/// (a form with the VHGP's priors and boxes: VhgpHyperprior::configured) and σ_n ∈ [1e-6, 1e2]. Starts: `warm`
/// (the previous solution, [θ_f ; log σ_n]) when given, and unless `warm_only`, the authors' start (amplitude² =
/// var(y), σ_n² = var(y)/4) with every lengthscale at 0.5, 0.15, 0.05.
HomoscedasticFit fit_homoscedastic(const Mat& X, const Vec& y, const Kernel& kernel, double jitter,
                                   const VhgpHyperprior& prior, const Optimizer& optimizer, Rng& rng,
                                   const Vec* warm = nullptr, bool warm_only = false);

}  // namespace varbo::vhgp
