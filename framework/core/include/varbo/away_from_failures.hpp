#pragma once
// A region that keeps a search near the successful trials and away from the failed ones, for the choices made on
// a finished model (a policy selected at risk κ, the recommendation minimizing the posterior mean): the cost model
// knows nothing where trials failed, and its mean there is an extrapolation that a minimizer is drawn to.
#include "varbo/region.hpp"
#include "varbo/types.hpp"

namespace varbo {

/// x is inside when its nearest failed trial is at least kFailureMargin times as far as its nearest successful
/// one: c(x) = min_f ‖x − f‖² − m² min_s ‖x − s‖² ≥ 0 (gradient 2 (x − f*) − 2 m² (x − s*)). Around one success s and
/// one failure f that is a ball (Apollonius) holding s and reaching a third of the way towards f. The plain
/// nearest-trial rule (m = 1, the Voronoi cells) was tried first: a success at the edge of the data owns a cell
/// reaching far past the failures beside it (the cliff run of the red team, session 24: the selection came out at
/// x1 = 0.86, where trials fail beyond 0.7). Intersected with `inner`'s own constraint (e.g. typed linear
/// constraints). Holds references: `inner`, `successes` and `failed` must outlive it.
class AwayFromFailures final : public RegionConstraint {
 public:
  static constexpr double kFailureMargin = 2.0;
  /// `successes` and `failed`: one unit-cube point per row, both non-empty.
  AwayFromFailures(const RegionConstraint& inner, const Mat& successes, const Mat& failed);
  const Box& bounds() const override { return inner_.bounds(); }
  bool has_constraint() const override { return true; }
  double constraint(const Vec& x, Vec* grad) const override;
  Mat seeds() const override { return successes_; }

 private:
  const RegionConstraint& inner_;
  const Mat& successes_;
  const Mat& failed_;
};

}  // namespace varbo
