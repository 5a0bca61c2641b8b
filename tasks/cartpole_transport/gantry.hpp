#pragma once
// A cart on a rail carrying a load on a rigid rod (a gantry crane), driven by a saturated PD servo that
// tracks a reference trajectory. See README.md for the equations and the cost.
#include <array>

namespace varbo::transport {

struct GantryParams {
  double cart_mass = 1.0;     ///< M, kg
  double load_mass = 1.0;     ///< m, kg (random per episode in the task)
  double rod_length = 0.7;    ///< l, m (random per episode in the task)
  double gravity = 9.81;      ///< g, m/s²
  double cart_friction = 0.5; ///< b, N s/m (viscous)
  double pivot_damping = 0.02;///< c, N m s/rad
  double kp = 40.0;           ///< servo position gain, N/m
  double kd = 12.0;           ///< servo velocity gain, N s/m
  double force_limit = 20.0;  ///< |F| ≤ F_max, N
};

/// [x, ẋ, φ, φ̇]: cart position, its velocity, rod angle from hanging down (φ > 0 swings the load to +x), its rate.
using GantryState = std::array<double, 4>;

/// Servo force F = sat(kp (x_ref − x) + kd (ẋ_ref − ẋ)).
double servo_force(const GantryParams& p, const GantryState& s, double x_ref, double v_ref);

/// State derivative under the total horizontal force `force` on the cart (servo + disturbance).
GantryState gantry_derivative(const GantryParams& p, const GantryState& s, double force);

/// Total energy ½(M+m)ẋ² + m l ẋ φ̇ cos φ + ½ m l² φ̇² − m g l cos φ (conserved without force and damping).
double gantry_energy(const GantryParams& p, const GantryState& s);

}  // namespace varbo::transport
