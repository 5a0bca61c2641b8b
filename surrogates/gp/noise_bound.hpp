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
  Index pairs;   ///< the number of stages (the replicates, then pairs) that gave it (0: none)
};

/// Replicates first: each group of k costs at one θ gives Σ(y − ȳ)²/σ² ~ χ²_{k−1}; then the other points matched
/// greedily into disjoint pairs, nearest first (Euclidean distance), each difference d giving d²/(2σ²) ~ χ²_1 (a
/// noncentral one when the cost itself changes between the points: larger, so the bound stays conservative).
/// U = sqrt(S / q) over the first stages (the replicates, then the m nearest pairs; pairs at one distance enter
/// together), q the (alpha/M)-quantile of χ² with their degrees of freedom, M the number of U evaluated; the
/// minimum is below σ with probability at most alpha (Bonferroni). Every choice depends on the points, not on the
/// rows' order. Exact replicates of a deterministic cost give 0. Cost O(N² log N) for N points, small beside a
/// fit's O(N³) likelihood evaluations. Valid for noise of one level: where the noise varies, the quietest
/// near pairs bound it (the gp assumes one level anyway).
NearPairNoiseBound near_pair_noise_bound(const Mat& X, const Vec& y, double alpha);

}  // namespace varbo::gp
