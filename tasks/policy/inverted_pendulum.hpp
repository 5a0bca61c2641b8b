#pragma once
// Pendulum of OpenAI gym Pendulum-v0: a uniform rod (m = 1 kg, l = 1 m, g = 10 m/s²) driven by a torque
// |u| ≤ 2 Nm, α measured from upright: α̈ = 3g/(2l)·sin α + 3u/(m l²). Stabilization task with the paper's
// adapted reward (section 5.2): r_t = (1 − |α_t|/2°)/T, promoting zero steady-state error.
// Differences from gym (documented in README.md): RK4 instead of semi-implicit Euler, no speed clipping, and
// initial states near upright (stabilization, not swing-up).
#include "control_system.hpp"

namespace varbo::tasks {

struct InvertedPendulumParams {
  double mass = 1.0, length = 1.0, gravity = 10.0;
  double torque_max = 2.0;
  double dt = 0.05;
  Index steps = 200;
  double init_angle = 0.2;     ///< α0 ~ U(−a, a), rad
  double init_velocity = 0.2;  ///< α̇0 ~ U(−b, b), rad/s
};

class InvertedPendulum final : public ControlSystem {
 public:
  explicit InvertedPendulum(InvertedPendulumParams p = {}) : p_(p) {}
  Index state_dim() const override { return 2; }
  Vec derivative(const Vec& s, double u) const override;
  double reward(const Vec& s) const override;
  Vec initial_state(Rng& rng) const override;
  Vec state_scale() const override;
  double energy(const Vec& s) const override;
  Mat lqr_q() const override;
  double lqr_r() const override { return 1.0; }
  double force_limit() const override { return p_.torque_max; }
  double dt() const override { return p_.dt; }
  Index steps() const override { return p_.steps; }

 private:
  InvertedPendulumParams p_;
};

/// Angle wrapped into (−π, π].
double wrap_angle(double a);

}  // namespace varbo::tasks
