#include "transport_task.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "reference_trajectory.hpp"

namespace varbo::transport {

namespace {
// [x, ẋ, φ, φ̇, ∫tracking, ∫sway, ∫energy]: the integrals ride along in RK4 so the cost has the integrator's order.
using Augmented = std::array<double, 7>;

Augmented derivative(const GantryParams& p, const ReferenceTrajectory& ref, double distance, const Augmented& a,
                     double t, double disturbance) {
  const GantryState s{a[0], a[1], a[2], a[3]};
  double xr = 0, vr = 0;
  ref.at(t, xr, vr);
  const double f = servo_force(p, s, xr, vr);
  const GantryState d = gantry_derivative(p, s, f + disturbance);
  const double load_x = s[0] + p.rod_length * std::sin(s[2]);
  return {d[0], d[1], d[2], d[3], (load_x - distance) * (load_x - distance), s[2] * s[2], f * f};
}

Augmented axpy(const Augmented& a, const Augmented& k, double h) {
  Augmented out;
  for (std::size_t i = 0; i < a.size(); ++i) out[i] = a[i] + h * k[i];
  return out;
}
}  // namespace

std::array<double, 3> waypoints(const Vec& theta, double distance) {
  std::array<double, 3> w{};
  double done = 0;
  for (int i = 0; i < 3; ++i) {
    done += theta[i] * (distance - done);  // fraction of the remaining distance: the reference never backs up
    w[static_cast<std::size_t>(i)] = done;
  }
  return w;
}

TransportRollout simulate_transport(const Vec& theta, const TransportSettings& s, Rng& rng) {
  GantryParams p = s.gantry;
  // Per-episode load: unobserved by the policy, the source of θ-dependent cost variance (an aggressive motion
  // excites a swing whose size and phase depend on m and l). Truncated so the physics stays sensible.
  p.load_mass = std::max(0.2, s.gantry.load_mass + s.load_mass_std * rng.normal());
  p.rod_length = std::max(0.3, s.gantry.rod_length + s.rod_length_std * rng.normal());
  const std::array<double, 3> w = waypoints(theta, s.distance);
  const ReferenceTrajectory ref({0.0, w[0], w[1], w[2], s.distance}, {theta[3], theta[4], theta[5], theta[6]});
  Augmented a{};
  a[2] = s.initial_swing_std * rng.normal();  // the load may already swing when the episode starts
  const auto steps = static_cast<long>(std::ceil(s.horizon / s.dt - 1e-9));
  for (long k = 0; k < steps; ++k) {
    const double t = k * s.dt;
    const double h = std::min(s.dt, s.horizon - t);
    const double w = s.force_noise_std * rng.normal();  // zero-order-hold disturbance over this step
    // Classical RK4 (fixed step); the servo force is evaluated at every stage.
    const Augmented k1 = derivative(p, ref, s.distance, a, t, w);
    const Augmented k2 = derivative(p, ref, s.distance, axpy(a, k1, h / 2), t + h / 2, w);
    const Augmented k3 = derivative(p, ref, s.distance, axpy(a, k2, h / 2), t + h / 2, w);
    const Augmented k4 = derivative(p, ref, s.distance, axpy(a, k3, h), t + h, w);
    for (std::size_t i = 0; i < a.size(); ++i) a[i] += h / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]);
  }
  TransportRollout r;
  r.tracking = a[4];
  r.sway = a[5];
  r.energy = a[6];
  r.final_state = {a[0], a[1], a[2], a[3]};
  return r;
}

Domain TransportTask::domain() const {
  Vec lo(7), hi(7);
  lo << 0.05, 0.05, 0.05, 0.2, 0.2, 0.2, 0.2;
  hi << 0.95, 0.95, 0.95, 1.4, 1.4, 1.4, 1.4;
  return Domain{Box{lo, hi}, {"a1", "a2", "a3", "tau1", "tau2", "tau3", "tau4"}};
}

std::optional<Vec> TransportTask::initial_point() const {
  // Hand-made policy: waypoints at D/4, D/2, 3D/4 (fractions 1/4, 1/3, 1/2 of the remaining distance), one
  // second per segment: a slow, smooth 4 s transfer.
  return (Vec(7) << 0.25, 1.0 / 3.0, 0.5, 1.0, 1.0, 1.0, 1.0).finished();
}

Evaluation TransportTask::evaluate(const Vec& theta, Rng& rng) {
  Evaluation e;
  if (theta.size() != 7 || !theta.allFinite() || (theta.tail(4).array() <= 0).any()) {
    e.ok = false;
    e.error = fmt::format("cartpole_transport: expected 3 waypoint fractions and 4 positive durations, got [{}]",
                          fmt::join(theta.data(), theta.data() + theta.size(), ", "));
    return e;
  }
  const TransportRollout r = simulate_transport(theta, s_, rng);
  e.components = {{"tracking", r.tracking}, {"sway", r.sway}, {"energy", r.energy}};
  // cost = Σ w_c · component_c, summed in component order (varbo rescore repeats exactly this sum).
  e.cost = 0;
  for (const auto& [name, value] : e.components) e.cost += s_.weights.at(name) * value;
  if (!std::isfinite(e.cost)) {
    e.ok = false;
    e.error = "cartpole_transport: the simulation diverged";
  }
  return e;
}

}  // namespace varbo::transport
