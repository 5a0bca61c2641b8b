#include "swingup.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "varbo/option_set.hpp"

namespace varbo::tasks {

namespace {

// (φ, ω, ∫α dt): the angle integral rides along in the RK4 so the cost has the integrator's order.
struct Augmented {
  PendulumState x;
  double angle_integral = 0;
};

Augmented rk4_augmented(const PendulumParams& p, const Augmented& a, double u, double h) {
  auto f = [&](const PendulumState& s) {
    const auto d = pendulum_derivative(p, s, u);
    return std::array<double, 3>{d[0], d[1], angle_from_upright(s.phi)};
  };
  auto at = [&](const std::array<double, 3>& k, double c) {
    return PendulumState{a.x.phi + c * k[0], a.x.omega + c * k[1]};
  };
  const auto k1 = f(a.x);
  const auto k2 = f(at(k1, h / 2));
  const auto k3 = f(at(k2, h / 2));
  const auto k4 = f(at(k3, h));
  Augmented out;
  out.x.phi = a.x.phi + h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0]);
  out.x.omega = a.x.omega + h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1]);
  out.angle_integral = a.angle_integral + h / 6 * (k1[2] + 2 * k2[2] + 2 * k3[2] + k4[2]);
  return out;
}

}  // namespace

// Kuindersma 2013, section 5.2: u = τ if 0 ≤ t ≤ θ1, −τ if θ1 < t ≤ θ1 + θ2, τ if θ1 + θ2 < t ≤ T.
double bang_bang_torque(double t, double t1, double t2, double tau) {
  if (t <= t1) return tau;
  if (t <= t1 + t2) return -tau;
  return tau;
}

SwingupResult simulate_swingup(double t1, double t2, double tau_max, const SwingupSettings& s) {
  const PendulumParams& p = s.pendulum;
  Augmented a;  // hanging down at rest (φ = 0, ω = 0)
  SwingupResult r;
  double t = 0;
  int reversals = 0;
  // Steps never straddle a torque switch, so RK4 keeps its order on each smooth piece.
  const double breaks[3] = {t1, t1 + t2, s.horizon};
  while (t < s.horizon) {
    double next = s.horizon;
    for (double b : breaks)
      if (b > t + 1e-12) next = std::min(next, b);
    const double h = std::min(s.dt, next - t);
    const double u = bang_bang_torque(t + h / 2, t1, t2, tau_max);
    const Augmented b = rk4_augmented(p, a, u, h);
    if (angle_from_upright(b.x.phi) <= s.goal_tolerance) {
      // Entered the goal region inside this step: find the entry time by bisection on the length of
      // a partial RK4 step from the step's start (a smooth function of that length), to ~1e-15 s.
      double lo = 0, hi = h;
      for (int k = 0; k < 60 && hi - lo > 1e-15; ++k) {
        const double mid = 0.5 * (lo + hi);
        (angle_from_upright(rk4_augmented(p, a, u, mid).x.phi) <= s.goal_tolerance ? hi : lo) = mid;
      }
      const Augmented end = rk4_augmented(p, a, u, hi);
      if (end.x.omega * a.x.omega < 0) ++reversals;
      a = end;
      t += hi;
      r.reached = true;
      break;
    }
    if (b.x.omega * a.x.omega < 0) ++reversals;
    a = b;
    t += h;
  }
  r.t_end = r.reached ? t : s.horizon;
  r.final_state = a.x;
  r.swings = 1 + reversals;
  r.angle_cost = s.angle_weight * a.angle_integral;
  // u² = τ² on every piece of a bang-bang policy, so its integral is exact.
  r.effort_cost = s.effort_weight * tau_max * tau_max * r.t_end;
  r.cost = r.angle_cost + r.effort_cost;
  return r;
}

Domain SwingupTask::domain() const {
  return Domain{Box{Vec::Zero(2), Vec::Constant(2, s_.t_max)}, {"t1", "t2"}};
}

Evaluation SwingupTask::evaluate(const Vec& theta, Rng& rng) {
  Evaluation e;
  if (theta.size() != 2 || !(theta[0] >= 0) || !(theta[1] >= 0)) {
    e.ok = false;
    e.error = fmt::format("pendulum_swingup: expected two switching times >= 0, got [{}]",
                          fmt::join(theta.data(), theta.data() + theta.size(), ", "));
    return e;
  }
  // One τ_max per episode (the paper's unobserved actuator strength).
  const double tau = s_.tau_mean + s_.tau_std * rng.normal();
  const SwingupResult r = simulate_swingup(theta[0], theta[1], tau, s_);
  e.cost = r.cost;
  e.components = {{"angle", r.angle_cost}, {"effort", r.effort_cost}};
  return e;
}

namespace {
const OptionSet<SwingupSettings>& swingup_option_set() {
  using S = SwingupSettings;
  static const OptionSet<S> set{
      opt::real("tau_mean", &S::tau_mean, "mean of the per-episode maximum torque, Nm").above(0),
      opt::real("tau_std", &S::tau_std, "std of the per-episode maximum torque, Nm").at_least(0),
      opt::real("horizon", &S::horizon, "episode length T, s").above(0),
      opt::real("t_max", &S::t_max, "upper bound of both switching times, s").above(0),
      opt::real("dt", &S::dt, "RK4 step, s (cost converged to ~1e-7 relative at 1e-3)").above(0).at_most(0.05),
      opt::real("goal_tolerance", &S::goal_tolerance, "episode ends within this angle of upright, rad").above(0),
      opt::real("mass", opt::nested(&S::pendulum, &PendulumParams::mass), "pendulum mass, kg").above(0),
      opt::real("length", opt::nested(&S::pendulum, &PendulumParams::length), "pendulum length, m").above(0),
      opt::real("gravity", opt::nested(&S::pendulum, &PendulumParams::gravity), "gravitational acceleration, m/s^2")
          .above(0),
      opt::real("angle_weight", &S::angle_weight, "weight of the angle-from-upright integral").at_least(0),
      opt::real("effort_weight", &S::effort_weight, "weight of the squared-torque integral").at_least(0)};
  return set;
}
}  // namespace

std::vector<OptionSpec> swingup_options() { return swingup_option_set().specs(); }

SwingupSettings swingup_settings(const Options& o) { return swingup_option_set().read(o); }

}  // namespace varbo::tasks
