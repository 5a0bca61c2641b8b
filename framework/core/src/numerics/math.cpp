#include "varbo/math.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <map>
#include <mutex>

namespace varbo {

double normal_pdf(double u) { return 0.3989422804014327 * std::exp(-0.5 * u * u); }
double normal_cdf(double u) { return 0.5 * std::erfc(-u * M_SQRT1_2); }

double normal_log_cdf(double u) {
  if (u > -30.0) return std::log(normal_cdf(u));  // erfc is accurate down to here
  // Asymptotic series of the Mills ratio for the far lower tail.
  const double z = -u, z2 = z * z;
  const double series = 1.0 - 1.0 / z2 + 3.0 / (z2 * z2) - 15.0 / (z2 * z2 * z2);
  return -0.5 * z2 - std::log(z) - 0.5 * std::log(2.0 * M_PI) + std::log(series);
}

const GaussHermite& gauss_hermite(int n) {
  static std::mutex mutex;
  static std::map<int, GaussHermite> cache;
  std::lock_guard<std::mutex> lock(mutex);
  auto it = cache.find(n);
  if (it != cache.end()) return it->second;
  // Golub–Welsch: nodes are the eigenvalues of the symmetric Jacobi matrix with off-diagonal sqrt(k/2);
  // weights are sqrt(pi) times the squared first components of the eigenvectors.
  Mat J = Mat::Zero(n, n);
  for (int k = 1; k < n; ++k) J(k, k - 1) = J(k - 1, k) = std::sqrt(0.5 * k);
  Eigen::SelfAdjointEigenSolver<Mat> es(J);
  GaussHermite gh;
  gh.nodes = es.eigenvalues();
  gh.weights = std::sqrt(M_PI) * es.eigenvectors().row(0).transpose().array().square();
  return cache.emplace(n, std::move(gh)).first->second;
}

RobustCholesky robust_cholesky(const Mat& K, double initial, int max_tries) {
  RobustCholesky r;
  const double scale = std::max(K.diagonal().mean(), 1e-300);
  double jitter = 0;
  for (int t = 0; t <= max_tries; ++t) {
    if (!K.allFinite()) break;
    Mat A = K;
    A.diagonal().array() += jitter;
    r.llt.compute(A);
    if (r.llt.info() == Eigen::Success && r.llt.matrixLLT().diagonal().minCoeff() > 0) {
      r.jitter = jitter;
      r.ok = true;
      return r;
    }
    jitter = (jitter == 0) ? initial * scale : jitter * 10;
  }
  r.ok = false;
  r.jitter = jitter;
  return r;
}

double LogNormalPrior::log_density(double log_value, double* d_log_value) const {
  const double z = (log_value - mean) / sd;
  if (d_log_value) *d_log_value = -z / sd;
  return -0.5 * z * z - std::log(sd) - 0.5 * std::log(2.0 * M_PI);
}

}  // namespace varbo
