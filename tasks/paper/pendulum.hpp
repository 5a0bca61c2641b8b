#pragma once
// A torque-driven simple pendulum (point mass m on a massless rod of length l, no friction):
//   m l² φ'' = u − m g l sin φ,   φ = 0 hanging down, φ = ±π upright.
// Used by the swing-up task of Kuindersma et al. 2013, section 5.2.
#include <array>

namespace varbo::tasks {

struct PendulumParams {
  double mass = 1.0;     ///< kg (paper: 1)
  double length = 1.0;   ///< m (paper: 1)
  double gravity = 9.81; ///< m/s² (not stated in the paper; standard gravity)
};

struct PendulumState {
  double phi = 0;    ///< angle from hanging down, rad
  double omega = 0;  ///< angular velocity, rad/s
};

/// (φ', ω') at `s` under torque u.
std::array<double, 2> pendulum_derivative(const PendulumParams& p, const PendulumState& s, double u);
/// Total mechanical energy ½ m l² ω² − m g l cos φ (conserved when u = 0).
double pendulum_energy(const PendulumParams& p, const PendulumState& s);
/// Angle from the upright vertical, in [0, π] (the paper's α(t)).
double angle_from_upright(double phi);
/// One classical RK4 step of length h with constant torque u.
PendulumState rk4_step(const PendulumParams& p, const PendulumState& s, double u, double h);

}  // namespace varbo::tasks
