#include "pendulum.hpp"

#include <cmath>
#include <numbers>

namespace varbo::tasks {

std::array<double, 2> pendulum_derivative(const PendulumParams& p, const PendulumState& s, double u) {
  const double inertia = p.mass * p.length * p.length;
  return {s.omega, (u - p.mass * p.gravity * p.length * std::sin(s.phi)) / inertia};
}

double pendulum_energy(const PendulumParams& p, const PendulumState& s) {
  return 0.5 * p.mass * p.length * p.length * s.omega * s.omega - p.mass * p.gravity * p.length * std::cos(s.phi);
}

// std::remainder maps φ − π into [−π, π]; its magnitude is the distance to upright.
double angle_from_upright(double phi) { return std::abs(std::remainder(phi - std::numbers::pi, 2 * std::numbers::pi)); }

PendulumState rk4_step(const PendulumParams& p, const PendulumState& s, double u, double h) {
  auto at = [&](const PendulumState& base, const std::array<double, 2>& k, double c) {
    return PendulumState{base.phi + c * k[0], base.omega + c * k[1]};
  };
  const auto k1 = pendulum_derivative(p, s, u);
  const auto k2 = pendulum_derivative(p, at(s, k1, h / 2), u);
  const auto k3 = pendulum_derivative(p, at(s, k2, h / 2), u);
  const auto k4 = pendulum_derivative(p, at(s, k3, h), u);
  return {s.phi + h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0]),
          s.omega + h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])};
}

}  // namespace varbo::tasks
