#include "inverted_pendulum.hpp"

#include <cmath>
#include <numbers>

namespace varbo::tasks {

double wrap_angle(double a) {
  a = std::remainder(a, 2 * std::numbers::pi);
  return a <= -std::numbers::pi ? a + 2 * std::numbers::pi : a;
}

Vec InvertedPendulum::derivative(const Vec& s, double u) const {
  Vec d(2);
  d << s(1), 3 * p_.gravity / (2 * p_.length) * std::sin(s(0)) + 3 * u / (p_.mass * p_.length * p_.length);
  return d;
}

double InvertedPendulum::reward(const Vec& s) const {
  // Fröhlich 2021, section 5.2: r_t = (1 − |α_t|/2°)/T (the 1/T is applied by the rollout).
  return 1.0 - std::abs(wrap_angle(s(0))) * 180.0 / std::numbers::pi / 2.0;
}

Vec InvertedPendulum::initial_state(Rng& rng) const {
  Vec s(2);
  s << rng.uniform(-p_.init_angle, p_.init_angle), rng.uniform(-p_.init_velocity, p_.init_velocity);
  return s;
}

Vec InvertedPendulum::state_scale() const {
  Vec v(2);
  v << 0.3, 1.0;
  return v;
}

double InvertedPendulum::energy(const Vec& s) const {
  // Rod about its pivot: inertia m l²/3, centre of mass at height (l/2) cos α.
  return 0.5 * (p_.mass * p_.length * p_.length / 3) * s(1) * s(1) +
         p_.mass * p_.gravity * 0.5 * p_.length * std::cos(s(0));
}

Mat InvertedPendulum::lqr_q() const {
  // Deliberately poor tuning: a small angle weight against the unit torque weight gives a sluggish stabilizer
  // whose slow convergence loses much of the precision reward (1 − |α|/2°).
  Vec q(2);
  q << 0.5, 0.5;
  return q.asDiagonal();
}

}  // namespace varbo::tasks
