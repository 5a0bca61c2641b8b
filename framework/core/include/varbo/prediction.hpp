#pragma once
// One predictive type for homoscedastic and heteroscedastic surrogates (architecture note, section 3).
#include <cmath>
#include "varbo/types.hpp"

namespace varbo {

/// Predictive distribution at θ*, in cost units:
///   y* | g* ~ N(mean, latent_var + exp(g*)),  g* ~ N(log_noise_mean, log_noise_var)   (Kuindersma 2013, eq. 7)
/// A homoscedastic GP is the special case log_noise_var = 0, exp(log_noise_mean) = σ_n².
struct Prediction {
  double mean = 0;            ///< a*   E[y*]
  double latent_var = 0;      ///< c*²  variance of the latent cost f*
  double log_noise_mean = -30;///< μ*   mean of the log noise variance g*
  double log_noise_var = 0;   ///< σ*²  its variance (0 for a homoscedastic model)
  // Gradients with respect to θ* (unit-cube coordinates), filled when asked for.
  Vec d_mean, d_latent_var, d_log_noise_mean, d_log_noise_var;

  bool has_gradient() const { return d_mean.size() > 0; }
  /// E[exp(g*)] = exp(μ* + σ*²/2): the expected noise variance.
  double noise_var() const { return std::exp(log_noise_mean + 0.5 * log_noise_var); }
  /// V[y*] = c*² + exp(μ* + σ*²/2)   (Kuindersma 2013, section 2.2)
  double total_var() const { return latent_var + noise_var(); }
  double total_std() const { return std::sqrt(total_var()); }
  Vec d_noise_var() const { return noise_var() * (d_log_noise_mean + 0.5 * d_log_noise_var); }
  Vec d_total_var() const { return d_latent_var + d_noise_var(); }
  bool heteroscedastic() const { return log_noise_var > 0; }
};

}  // namespace varbo
