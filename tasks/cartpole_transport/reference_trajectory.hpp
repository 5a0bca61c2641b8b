#pragma once
// A 1-D reference trajectory through waypoints: piecewise cubic Hermite with waypoint velocities from the
// tangent method (Craig 2005, as in Kuindersma 2013, section 5.4): the mean of the adjacent segment slopes,
// or zero where the slope changes sign; zero velocity at both ends.
#include <vector>

namespace varbo::transport {

class ReferenceTrajectory {
 public:
  /// `positions` (n+1 knots, first = start, last = goal) reached after the segment `durations` (n, all > 0).
  ReferenceTrajectory(std::vector<double> positions, const std::vector<double>& durations);
  /// Position and velocity at time t (held at the goal after the last knot, at the start before 0).
  void at(double t, double& position, double& velocity) const;
  double end_time() const { return times_.back(); }

 private:
  std::vector<double> p_, v_, times_;
};

}  // namespace varbo::transport
