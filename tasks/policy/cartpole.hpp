#pragma once
// Cart-pole of OpenAI gym CartPole-v1 (Barto, Sutton & Anderson 1983; equations as in gym): a cart (1 kg) with a
// uniform pole (0.1 kg, half-length 0.5 m), frictionless, continuous horizontal force u.
// State s = (x, ẋ, ϑ, ϑ̇), ϑ from upright. The paper's adapted reward (section 5.2): r_t = (1 − |x_t|)/T, so
// the cart must stay at the centre; the episode stops (no further reward) when |x| > 2.4 m or |ϑ| > 12°.
#include "control_system.hpp"

namespace varbo::tasks {

struct CartPoleParams {
  double cart_mass = 1.0, pole_mass = 0.1, half_length = 0.5, gravity = 9.8;
  double force_max = 10.0;   ///< |u| limit, N (gym's force magnitude)
  double dt = 0.02;          ///< s (gym's tau)
  Index steps = 500;         ///< T (CartPole-v1)
  double x_limit = 2.4, angle_limit = 12.0 * 3.14159265358979323846 / 180.0;
  double init_position = 0.5;  ///< x0 ~ U(−a, a): the cart starts off-centre so that centering matters
  double init_other = 0.05;    ///< ẋ0, ϑ0, ϑ̇0 ~ U(−b, b) (gym's 0.05)
};

class CartPole final : public ControlSystem {
 public:
  explicit CartPole(CartPoleParams p = {}) : p_(p) {}
  Index state_dim() const override { return 4; }
  Vec derivative(const Vec& s, double u) const override;
  double reward(const Vec& s) const override { return 1.0 - std::abs(s(0)); }
  bool failed(const Vec& s) const override;
  Vec initial_state(Rng& rng) const override;
  Vec state_scale() const override;
  double energy(const Vec& s) const override;
  Mat lqr_q() const override;
  double lqr_r() const override { return 1.0; }
  double force_limit() const override { return p_.force_max; }
  double dt() const override { return p_.dt; }
  Index steps() const override { return p_.steps; }

 private:
  CartPoleParams p_;
};

}  // namespace varbo::tasks
