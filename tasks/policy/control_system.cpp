#include "control_system.hpp"

#include <cmath>

#include "varbo/log.hpp"

namespace varbo::tasks {

Vec rk4_step(const ControlSystem& sys, const Vec& s, double u, double h) {
  const Vec k1 = sys.derivative(s, u);
  const Vec k2 = sys.derivative(s + 0.5 * h * k1, u);
  const Vec k3 = sys.derivative(s + 0.5 * h * k2, u);
  const Vec k4 = sys.derivative(s + h * k3, u);
  return s + (h / 6.0) * (k1 + 2 * k2 + 2 * k3 + k4);
}

Vec lqr_gain(const ControlSystem& sys) {
  const Index n = sys.state_dim();
  const double h = sys.dt(), eps = 1e-6;
  const Vec zero = Vec::Zero(n);
  Mat A(n, n);
  Vec B(n);
  for (Index j = 0; j < n; ++j) {
    Vec e = Vec::Zero(n);
    e(j) = eps;
    A.col(j) = (rk4_step(sys, e, 0, h) - rk4_step(sys, -e, 0, h)) / (2 * eps);
  }
  B = (rk4_step(sys, zero, eps, h) - rk4_step(sys, zero, -eps, h)) / (2 * eps);
  const Mat Q = sys.lqr_q();
  const double R = sys.lqr_r();
  Mat P = Q;
  Vec K = Vec::Zero(n);
  for (int it = 0; it < 100000; ++it) {
    // Discrete Riccati: K = (R + BᵀPB)⁻¹ BᵀPA,  P = Q + AᵀP(A − BK).
    const double denom = R + B.dot(P * B);
    const Vec Knew = (B.transpose() * P * A).transpose() / denom;
    const Mat Pnew = Q + A.transpose() * P * (A - B * Knew.transpose());
    const double change = (Pnew - P).norm() / std::max(1.0, P.norm());
    P = 0.5 * (Pnew + Pnew.transpose());
    K = Knew;
    if (change < 1e-13) break;
  }
  return K;
}

}  // namespace varbo::tasks
