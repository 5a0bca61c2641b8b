#include "reference_trajectory.hpp"

#include <stdexcept>

namespace varbo::transport {

ReferenceTrajectory::ReferenceTrajectory(std::vector<double> positions, const std::vector<double>& durations)
    : p_(std::move(positions)) {
  if (p_.size() != durations.size() + 1 || durations.empty())
    throw std::invalid_argument("ReferenceTrajectory: expected n+1 positions for n durations");
  times_.push_back(0.0);
  for (double d : durations) {
    if (!(d > 0)) throw std::invalid_argument("ReferenceTrajectory: durations must be > 0");
    times_.push_back(times_.back() + d);
  }
  const std::size_t n = durations.size();
  v_.assign(n + 1, 0.0);
  for (std::size_t i = 1; i < n; ++i) {
    const double left = (p_[i] - p_[i - 1]) / durations[i - 1];
    const double right = (p_[i + 1] - p_[i]) / durations[i];
    v_[i] = left * right > 0 ? 0.5 * (left + right) : 0.0;  // tangent method
  }
}

void ReferenceTrajectory::at(double t, double& position, double& velocity) const {
  if (t <= 0) {
    position = p_.front();
    velocity = 0;
    return;
  }
  if (t >= times_.back()) {
    position = p_.back();
    velocity = 0;
    return;
  }
  std::size_t i = 0;
  while (t > times_[i + 1]) ++i;
  const double h = times_[i + 1] - times_[i];
  const double s = (t - times_[i]) / h;
  // Cubic Hermite basis on [0, 1] and its derivative.
  const double h00 = 2 * s * s * s - 3 * s * s + 1, h10 = s * s * s - 2 * s * s + s;
  const double h01 = -2 * s * s * s + 3 * s * s, h11 = s * s * s - s * s;
  const double d00 = 6 * s * s - 6 * s, d10 = 3 * s * s - 4 * s + 1, d01 = -6 * s * s + 6 * s, d11 = 3 * s * s - 2 * s;
  position = h00 * p_[i] + h10 * h * v_[i] + h01 * p_[i + 1] + h11 * h * v_[i + 1];
  velocity = (d00 * p_[i] + d10 * h * v_[i] + d01 * p_[i + 1] + d11 * h * v_[i + 1]) / h;
}

}  // namespace varbo::transport
