#include "gantry.hpp"

#include <algorithm>
#include <cmath>

namespace varbo::transport {

double servo_force(const GantryParams& p, const GantryState& s, double x_ref, double v_ref) {
  return std::clamp(p.kp * (x_ref - s[0]) + p.kd * (v_ref - s[1]), -p.force_limit, p.force_limit);
}

GantryState gantry_derivative(const GantryParams& p, const GantryState& s, double force) {
  // Lagrange's equations of cart (M, x) + point load (m) on a massless rod (l, φ):
  //   (M+m) ẍ + m l cos φ φ̈ = F − b ẋ + m l sin φ φ̇²
  //   m l cos φ ẍ + m l² φ̈  = −m g l sin φ − c φ̇
  const double M = p.cart_mass, m = p.load_mass, l = p.rod_length;
  const double c = std::cos(s[2]), sn = std::sin(s[2]);
  const double a11 = M + m, a12 = m * l * c, a22 = m * l * l;
  const double r1 = force - p.cart_friction * s[1] + m * l * sn * s[3] * s[3];
  const double r2 = -m * p.gravity * l * sn - p.pivot_damping * s[3];
  const double det = a11 * a22 - a12 * a12;  // = m l² (M + m sin² φ) > 0
  return {s[1], (a22 * r1 - a12 * r2) / det, s[3], (a11 * r2 - a12 * r1) / det};
}

double gantry_energy(const GantryParams& p, const GantryState& s) {
  const double M = p.cart_mass, m = p.load_mass, l = p.rod_length;
  return 0.5 * (M + m) * s[1] * s[1] + m * l * s[1] * s[3] * std::cos(s[2]) + 0.5 * m * l * l * s[3] * s[3] -
         m * p.gravity * l * std::cos(s[2]);
}

}  // namespace varbo::transport
