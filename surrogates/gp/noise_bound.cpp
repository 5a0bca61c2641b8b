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
  // Rows in lexicographic order of θ: every choice below depends on the points, never on the rows' order (red
  // team, session 25: with replicates in a quiet region listed first the bound was 5× below that of the same data
  // reversed, and it capped the fitted noise).
  auto x_less = [&](Index a, Index b) {
    for (Index k = 0; k < X.cols(); ++k)
      if (X(a, k) != X(b, k)) return X(a, k) < X(b, k);
    return false;
  };
  std::vector<Index> order(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) order[static_cast<std::size_t>(i)] = i;
  std::stable_sort(order.begin(), order.end(), x_less);
  // Stage 0, the replicates: a group of k costs at one θ gives Σ (y − ȳ)² / σ² ~ χ²_{k−1}, whatever the rows'
  // order (pairing replicates instead would pick among them). Members of a group are not paired further.
  struct Stage {
    double ss;    ///< the sum of squares that stage adds: Σ(y − ȳ)² of groups, d²/2 of a pair
    double dof;   ///< its degrees of freedom
    double dist2; ///< squared distance of its points (0 for replicates)
  };
  std::vector<Stage> stages;
  std::vector<char> used(static_cast<std::size_t>(n), 0);
  double rep_ss = 0, rep_dof = 0;
  for (std::size_t a = 0; a < order.size();) {
    std::size_t b = a + 1;
    while (b < order.size() && !x_less(order[a], order[b])) ++b;  // equal θ (sorted: no smaller one follows)
    if (b - a >= 2) {
      std::vector<double> v;  // summed in the order of the costs: the same bits whatever the rows' order
      for (std::size_t k = a; k < b; ++k) {
        v.push_back(y(order[k]));
        used[static_cast<std::size_t>(order[k])] = 1;
      }
      std::sort(v.begin(), v.end());
      double mean = 0;
      for (double c : v) mean += c;
      mean /= static_cast<double>(v.size());
      for (double c : v) rep_ss += (c - mean) * (c - mean);
      rep_dof += static_cast<double>(v.size() - 1);
    }
    a = b;
  }
  if (rep_dof > 0) stages.push_back({rep_ss, rep_dof, 0.0});
  // Then distinct points matched greedily into disjoint pairs, nearest first; a difference d gives d² / (2σ²) ~ χ²_1.
  struct Pair {
    double dist2;
    Index i, j;  ///< i before j in θ's order
  };
  std::vector<Pair> all;
  for (std::size_t a = 0; a < order.size(); ++a) {
    if (used[static_cast<std::size_t>(order[a])]) continue;
    for (std::size_t b = a + 1; b < order.size(); ++b)
      if (!used[static_cast<std::size_t>(order[b])])
        all.push_back({(X.row(order[a]) - X.row(order[b])).squaredNorm(), order[a], order[b]});
  }
  // Ties in distance broken by the points (θ order), so the matching is a function of the set of points.
  std::stable_sort(all.begin(), all.end(), [&](const Pair& p, const Pair& q) { return p.dist2 < q.dist2; });
  for (const Pair& p : all) {
    if (used[static_cast<std::size_t>(p.i)] || used[static_cast<std::size_t>(p.j)]) continue;
    used[static_cast<std::size_t>(p.i)] = used[static_cast<std::size_t>(p.j)] = 1;
    const double d = y(p.i) - y(p.j);
    stages.push_back({0.5 * d * d, 1.0, p.dist2});
  }
  if (stages.empty()) return out;
  // U_m = sqrt(S_m / q_m) over the first m stages, evaluated where the distance grows (stages at one distance enter
  // together: no prefix of equally near pairs is preferred); Bonferroni over the evaluations.
  std::size_t tests = 0;
  for (std::size_t m = 1; m <= stages.size(); ++m) tests += m == stages.size() || stages[m].dist2 != stages[m - 1].dist2;
  const double level = alpha / static_cast<double>(tests);
  double sum = 0, dof = 0;
  for (std::size_t m = 1; m <= stages.size(); ++m) {
    sum += stages[m - 1].ss;
    dof += stages[m - 1].dof;
    if (m < stages.size() && stages[m].dist2 == stages[m - 1].dist2) continue;
    const double u = std::sqrt(sum / chi2_quantile(dof, level));
    if (u < out.bound) out = {u, static_cast<Index>(m)};
  }
  return out;
}

}  // namespace varbo::gp
