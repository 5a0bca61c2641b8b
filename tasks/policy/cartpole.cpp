#include "cartpole.hpp"

#include <cmath>

namespace varbo::tasks {

Vec CartPole::derivative(const Vec& s, double u) const {
  // gym cartpole.py (Florian 2007, frictionless): Lagrangian dynamics of a cart and a uniform rod.
  const double m = p_.pole_mass, l = p_.half_length, mt = p_.cart_mass + p_.pole_mass;
  const double th = s(2), thd = s(3), c = std::cos(th), sn = std::sin(th);
  const double temp = (u + m * l * thd * thd * sn) / mt;
  const double thacc = (p_.gravity * sn - c * temp) / (l * (4.0 / 3.0 - m * c * c / mt));
  const double xacc = temp - m * l * thacc * c / mt;
  Vec d(4);
  d << s(1), xacc, thd, thacc;
  return d;
}

bool CartPole::failed(const Vec& s) const {
  return std::abs(s(0)) > p_.x_limit || std::abs(s(2)) > p_.angle_limit || !s.allFinite();
}

Vec CartPole::initial_state(Rng& rng) const {
  Vec s(4);
  s << rng.uniform(-p_.init_position, p_.init_position), rng.uniform(-p_.init_other, p_.init_other),
      rng.uniform(-p_.init_other, p_.init_other), rng.uniform(-p_.init_other, p_.init_other);
  return s;
}

Vec CartPole::state_scale() const {
  Vec v(4);
  v << 1.0, 1.0, 0.2, 1.0;
  return v;
}

double CartPole::energy(const Vec& s) const {
  // Cart: ½Mẋ²; rod: centre of mass at (x + l sinϑ, l cosϑ), inertia m l²/3 about it.
  const double m = p_.pole_mass, l = p_.half_length, xd = s(1), th = s(2), thd = s(3);
  const double vx = xd + l * thd * std::cos(th), vy = -l * thd * std::sin(th);
  return 0.5 * p_.cart_mass * xd * xd + 0.5 * m * (vx * vx + vy * vy) + 0.5 * (m * l * l / 3) * thd * thd +
         m * p_.gravity * l * std::cos(th);
}

Mat CartPole::lqr_q() const {
  // Deliberately poor tuning of the initial controller: the pole angle is weighted, the cart position barely,
  // so the pole is balanced but the cart drifts back to the centre only slowly (low reward (1 − |x|)/T).
  Vec q(4);
  q << 0.001, 0.0, 1.0, 0.1;
  return q.asDiagonal();
}

}  // namespace varbo::tasks
