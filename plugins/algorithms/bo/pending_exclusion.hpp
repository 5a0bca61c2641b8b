#pragma once
// A θ that is pending (handed to another worker, or earlier in the same batch) is not handed out again.
//
// Why it happens at all: the kriging believer (Ginsbourger, Le Riche & Carraro 2010, section 3) conditions the
// model on a pending point at its own posterior mean. That does not move the mean there and leaves the predictive
// sd at the fitted noise level, so once a search has converged EI can still peak at the pending θ itself, and the
// final refinement's posterior-mean minimum (cb with κ = 0) is exactly where it was: two workers would run one trial
// twice (found with two Study handles on a bowl: trials 19 and 20 at the same θ). When the acquisition's best point
// lies within `pending_distance` (∞-norm, unit cube) of a pending point, bo maximizes it once more with those
// neighbourhoods excluded by AwayFromPoints. Runs without pending points are unchanged.
#include <optional>
#include <string>
#include <vector>

#include "varbo/acquisition.hpp"

namespace varbo::bo {

/// The first of `points` within `radius` (∞-norm) of x, or -1.
Index nearest_within(const Vec& x, const std::vector<Vec>& points, double radius);

/// Inside an ∞-norm ball of `radius` around one of `centres` (strictly): `floor` − 1 − (radius − d)/radius, lowest
/// at the centre, with its gradient (outwards along the coordinate that sets the ∞-norm) when grad is non-null;
/// nullopt outside every ball. The exclusion both AwayFromPoints and bo's boundary_tabu use.
std::optional<double> excluded_ball_value(const Vec& x, const std::vector<Vec>& centres, double radius, double floor,
                                          Vec* grad);

/// `inner` outside the ∞-norm balls of `radius` around `points`; inside them a value below `floor` − 1, rising
/// linearly towards the balls' faces (gradient included), so a local maximizer started inside climbs out.
/// `floor` should be a value the maximizer can beat anywhere else: below_values() gives min(0, inner at the data).
class AwayFromPoints final : public Acquisition {
 public:
  AwayFromPoints(const Acquisition& inner, std::vector<Vec> points, double radius, double floor);
  void prepare(const AcquisitionContext&) override {}  // the inner acquisition is already prepared
  double evaluate(const Vec& x, Vec* grad) const override;
  bool has_gradient() const override { return inner_.has_gradient(); }
  std::string state() const override;

  /// min(0, min over the rows of X of inner's finite values).
  static double below_values(const Acquisition& inner, const Mat& X);

 private:
  const Acquisition& inner_;
  std::vector<Vec> points_;
  double radius_;
  double floor_;
};

}  // namespace varbo::bo
