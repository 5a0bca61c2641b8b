#pragma once
// The probability that a trial at θ succeeds, learned from successes and failures: a GP classifier with a
// probit link and the Laplace approximation (Rasmussen & Williams 2006, section 3.4, Algorithms 3.1 and 3.2).
//
// Why Laplace rather than a GP regression on a ±1 indicator: the regression treats the labels as Gaussian, so
// its "probability" is not bounded, a cluster of failures counts no more than one, and its variance ignores that
// a label is binary. The probit likelihood is log-concave, so the Laplace mode is unique and Newton's method
// finds it in a handful of steps (R&W section 3.4.1); the predictive P(success | x) = Φ(μ*/√(1 + σ*²)) (R&W
// eq. 3.82) is closed form and differentiable in x, which the gradient-based acquisition optimizers need. EP
// would be somewhat better calibrated but is iterative over sites and needs more code for the same decisions.
//
// Hyperparameters: a Matérn-5/2 ARD kernel whose lengthscales are the cost model's times a factor, a signal std,
// and a constant prior mean m of the latent set from a smoothed success rate p̄ = (s + 1)/(n + 2), so that far
// from every trial P(success) = p̄ (empirical Bayes; BO counts its space-filling initial design only, see
// bayesian_optimization.cpp). The factor and the signal std are chosen on a small fixed grid
// by the Laplace approximation of the evidence (R&W eq. 3.32): deterministic, no random restarts.
#include <limits>
#include <vector>

#include "kernel.hpp"
#include "varbo/types.hpp"

namespace varbo::bo {

/// Derivatives of the probit log-likelihood log Φ(y f) for a label y = ±1 (R&W Table 3.1).
struct ProbitTerms {
  double log_likelihood = 0;
  double d1 = 0;  ///< ∂/∂f log Φ(y f) = y φ(z)/Φ(z), z = y f
  double w = 0;   ///< −∂²/∂f² log Φ(y f) = λ² + zλ, λ = φ(z)/Φ(z)  (≥ 0: log-concave)
};
ProbitTerms probit_terms(double y, double f);

/// The classifier's hyperparameters (outside the class so it can be a default argument).
struct FeasibilityHyper {
  double lengthscale_factor = 1;  ///< × the base lengthscales
  double signal_std = 2;          ///< of the latent
  Vec dim_factor = Vec();         ///< per dimension, × the above (empty = 1 in every dimension)
};

class FeasibilityModel {
 public:
  using Hyper = FeasibilityHyper;

  explicit FeasibilityModel(Index dim);

  /// The probability of success far from every trial (the prior mean's target); NaN (default) = the smoothed
  /// success rate (s + 1)/(n + 2) of the labels given to fit().
  void set_prior_success_rate(double rate) { prior_rate_ = rate; }

  /// Fits on points X (rows, unit cube) with labels success[i]. `base_lengthscales` (unit cube, one per
  /// dimension) come from the cost model. When `select` is true the factor and signal std are chosen on the grid
  /// by the Laplace evidence, else `hyper` is used. Returns false (model not ready) if nothing could be fitted.
  bool fit(const Mat& X, const std::vector<bool>& success, const Vec& base_lengthscales, bool select = true,
           Hyper hyper = {});

  /// With `ard` true, fit(select = true) follows the grid search by a per-dimension search of the lengthscales
  /// (coordinate ascent of the Laplace evidence over dim_factor ∈ ard_factors(), two sweeps): a failure region
  /// bounded in a few coordinates (a slab x6 > 0.7) is learned as such, with long lengthscales along the others.
  void set_ard(bool ard) { ard_ = ard; }
  /// With `fit` true, fit(select = true) prefers hyperparameters under which every failed point without a
  /// success within 0.01 (max-norm) has a negative latent mode (P(success) < 0.5 there) to any that explain such a
  /// failure away as noise; among those alike, the evidence decides (session 37).
  void set_fit_failures(bool fit) { fit_failures_ = fit; }
  /// The per-dimension multipliers searched when set_ard(true).
  static std::vector<double> ard_factors();

  /// P(success | x), x in the unit cube; fills grad (∂P/∂x) when non-null. Thread-safe (const, no caches).
  double probability(const Vec& x, Vec* grad = nullptr) const;
  /// Latent predictive mean and variance at x (R&W Algorithm 3.2), for tests and logs.
  void latent(const Vec& x, double& mean, double& variance) const;

  bool ready() const { return ready_; }
  const Hyper& hyper() const { return hyper_; }
  double prior_mean() const { return prior_mean_; }
  /// P(success) far from every trial: Φ(m/√(1 + σ²)) = the smoothed success rate (s + 1)/(n + 2).
  double prior_probability() const;
  double log_evidence() const { return log_evidence_; }
  const Vec& mode() const { return f_; }  ///< the Laplace mode f̂ at the training points

  /// The hyperparameter grid searched by fit(select = true).
  static std::vector<Hyper> grid();

 private:
  /// Newton iterations for the mode with hyperparameters h (R&W Algorithm 3.1, with step halving as a
  /// safeguard); fills the state below and returns the approximate log evidence (−inf on failure).
  double laplace(const Mat& X, const Vec& y, const Vec& base_lengthscales, const Hyper& h);

  Index dim_;
  bool ready_ = false;
  Hyper hyper_;
  double prior_mean_ = 0;
  double prior_rate_ = std::numeric_limits<double>::quiet_NaN();
  double log_evidence_ = 0;
  bool ard_ = false;
  bool fit_failures_ = false;
  std::vector<Index> must_fit_;  ///< failed points without a success within 0.01 (set_fit_failures)
  bool fits_failures_ = true;    ///< laplace(): every point of must_fit_ has a negative mode
  kernels::ArdKernel kernel_;
  Mat X_;
  Vec f_;           ///< mode
  Vec dlik_;        ///< ∇ log p(y | f̂)
  Vec sqrt_w_;      ///< W^½ at the mode
  Mat L_;           ///< Cholesky factor of B = I + W^½ K W^½ (lower)
};

}  // namespace varbo::bo
