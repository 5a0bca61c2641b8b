#include "noise_bound.hpp"

#include <algorithm>
#include <boost/math/special_functions/gamma.hpp>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace varbo::gp {

double chi2_quantile(double dof, double p) {
  if (!(dof > 0) || !(p > 0 && p < 1)) throw std::invalid_argument("chi2_quantile: needs dof > 0 and 0 < p < 1");
  // P(χ²_k ≤ x) = P(k/2, x/2), the regularized lower incomplete gamma function.
  return 2.0 * boost::math::gamma_p_inv(0.5 * dof, p);
}

NearPairNoiseBound near_pair_noise_bound(const Mat& X, const Vec& y, double alpha) {
  if (!(alpha > 0 && alpha < 1)) throw std::invalid_argument("near_pair_noise_bound: needs 0 < alpha < 1");
  if (X.rows() != y.size()) throw std::invalid_argument("near_pair_noise_bound: X and y differ in length");
  const Index n = X.rows();
  NearPairNoiseBound out{std::numeric_limits<double>::infinity(), 0};
  if (n < 2) return out;
  struct Pair {
    double dist2;
    Index i, j;
  };
  std::vector<Pair> all;
  all.reserve(static_cast<std::size_t>(n * (n - 1) / 2));
  for (Index i = 0; i < n; ++i)
    for (Index j = i + 1; j < n; ++j) all.push_back({(X.row(i) - X.row(j)).squaredNorm(), i, j});
  // Ties broken by index: the matching, hence the bound, is a function of X alone.
  std::sort(all.begin(), all.end(), [](const Pair& a, const Pair& b) {
    return a.dist2 != b.dist2 ? a.dist2 < b.dist2 : (a.i != b.i ? a.i < b.i : a.j < b.j);
  });
  std::vector<char> used(static_cast<std::size_t>(n), 0);
  std::vector<double> diff2;
  for (const Pair& p : all) {
    if (used[static_cast<std::size_t>(p.i)] || used[static_cast<std::size_t>(p.j)]) continue;
    used[static_cast<std::size_t>(p.i)] = used[static_cast<std::size_t>(p.j)] = 1;
    const double d = y(p.i) - y(p.j);
    diff2.push_back(d * d);
  }
  const double level = alpha / static_cast<double>(diff2.size());
  double sum = 0;
  for (std::size_t m = 1; m <= diff2.size(); ++m) {
    sum += diff2[m - 1];
    const double u = std::sqrt(sum / (2.0 * chi2_quantile(static_cast<double>(m), level)));
    if (u < out.bound) out = {u, static_cast<Index>(m)};
  }
  return out;
}

}  // namespace varbo::gp
