#pragma once
// A test for noise on the data themselves: an upper confidence bound on the noise std from the differences of the
// costs at the nearest pairs of points. A GP's marginal likelihood cannot tell rugged deterministic structure
// (Ackley's ripples) from noise of the same size — it explains both with the same σ_n — but near pairs can: with
// noise σ two costs differ by ~σ√2 however close their points are, while a deterministic cost changes by its slope
// times the distance (docs/defaults.md, "Session se15").
#include "varbo/types.hpp"

namespace varbo::gp {

/// The p-quantile of the χ² distribution with `dof` degrees of freedom (0 < p < 1).
double chi2_quantile(double dof, double p);

struct NearPairNoiseBound {
  double bound;  ///< upper confidence bound on the noise std, in the units of y (+inf: fewer than two points)
  Index pairs;   ///< the number of nearest pairs that gave it (0: none)
};

/// Matches the points greedily into disjoint pairs, nearest first (Euclidean distance; the pairs depend on X only),
/// and for each m = 1..M bounds the noise std by U_m = sqrt(S_m / (2 q_m)), S_m the sum of the m nearest pairs'
/// squared cost differences and q_m the (alpha/M)-quantile of χ²_m. With independent Gaussian noise σ each
/// difference is N(δ_k, 2σ²), δ_k the cost's own change, so S_m / (2σ²) is a (noncentral) χ²_m and
/// P(U_m < σ) ≤ alpha/M whatever the δ_k; the minimum over m is below σ with probability at most alpha
/// (Bonferroni). Exact replicates of a deterministic cost give 0. Cost O(N² log N) for N points (every pair sorted),
/// small beside a fit's O(N³) likelihood evaluations.
NearPairNoiseBound near_pair_noise_bound(const Mat& X, const Vec& y, double alpha);

}  // namespace varbo::gp
