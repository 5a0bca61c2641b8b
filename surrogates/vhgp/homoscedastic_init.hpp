#pragma once
// A quick homoscedastic GP fit used to initialize the VHGP: the authors' driver first fits
// y ~ GP(0, k_f + σ_n² δ) and starts the VHGP from its k_f hyperparameters and noise level (vhgp.md, section 8).
#include "varbo/optimizer.hpp"
#include "vhgp_objective.hpp"

namespace varbo::vhgp {

struct HomoscedasticFit {
  bool ok = false;
  Vec theta_f;               ///< [log ℓ ; log σ_f]
  double log_noise_var = 0;  ///< log σ_n²
  double log_likelihood = 0;
};

/// log N(y | 0, K_f + σ_n² I) and its gradient over [θ_f ; log σ_n] (Rasmussen & Williams eq. 5.8–5.9).
double homoscedastic_log_likelihood(const Mat& X, const Vec& y, KernelType type, double jitter, const Vec& x,
                                    Vec* grad);

/// Maximizes the homoscedastic likelihood (+ the f and μ0 hyperpriors when enabled) from the authors' start:
/// ℓ = ½ (half the unit range), σ_f² = var(y), σ_n² = var(y)/4.
HomoscedasticFit fit_homoscedastic(const Mat& X, const Vec& y, KernelType type, double jitter,
                                   const VhgpHyperprior& prior, const Optimizer& optimizer, Rng& rng);

}  // namespace varbo::vhgp

namespace varbo::vhgp {

/// A heteroscedastic start from the homoscedastic fit: the leave-one-out residuals e_i of the GP give noisy
/// observations t_i = log e_i² + 1.27 of the log noise variance (E[log χ²₁] = −1.27, Var = π²/2); smoothing them
/// with the g kernel, μ = K_g(K_g + π²/2·I)⁻¹(t − μ0) + μ0, gives β = Λ − ½ = (K_g + π²/2·I)⁻¹(t − μ0), so that
/// q(g) starts with a noise model that already varies over the domain instead of the constant μ0 of Λ = ½.
/// Returns log Λ (Λ floored at 1e-3, where β would be < −½); sets *mu0 and *theta_g (σ_g from the spread of t).
Vec residual_log_lambda(const Mat& X, const Vec& y, KernelType f_type, double jitter, const HomoscedasticFit& fit,
                        KernelType g_type, Vec* theta_g, double* mu0);

}  // namespace varbo::vhgp
