#pragma once
// Numerical helpers shared by models and acquisitions: normal density/CDF, Gauss–Hermite rules,
// Cholesky with adaptive jitter, log-normal hyperpriors, unit-cube maps.
#include <Eigen/Cholesky>
#include "varbo/types.hpp"

namespace varbo {

double normal_pdf(double u);
double normal_cdf(double u);
/// log Φ(u), accurate far in the lower tail.
double normal_log_cdf(double u);

/// Gauss–Hermite rule for weight e^{-t²} with n nodes (Golub–Welsch on the Jacobi matrix).
struct GaussHermite {
  Vec nodes;
  Vec weights;
};
const GaussHermite& gauss_hermite(int n);

/// Cholesky factor of K + jitter·I, with jitter grown from 0 (then `initial` × mean diagonal, ×10 per try)
/// until the factorization succeeds. ok = false after `max_tries`.
struct RobustCholesky {
  Eigen::LLT<Mat> llt;
  double jitter = 0;
  bool ok = false;
};
RobustCholesky robust_cholesky(const Mat& K, double initial = 1e-10, int max_tries = 10);

/// Independent log-normal prior on a positive hyperparameter ψ: log ψ ~ N(mean, sd²) (Kuindersma 2013, eq. 13).
/// Evaluated as the density of log ψ, so its gradient w.r.t. log ψ is −(log ψ − mean)/sd².
struct LogNormalPrior {
  double mean = 0;
  double sd = 1;
  double log_density(double log_value, double* d_log_value = nullptr) const;
};

Vec to_unit(const Vec& theta, const Box& box);
Vec from_unit(const Vec& u, const Box& box);

}  // namespace varbo
