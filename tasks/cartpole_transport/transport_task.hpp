#pragma once
// Gantry transport task: move a swinging load by `distance` with a reference trajectory through three
// waypoints and four segment durations (7 policy parameters); cost = Σ w_c · component_c with components
// tracking (load distance to the goal), sway (rod angle) and energy (squared servo force). See README.md.
#include <array>
#include <map>
#include <string>

#include "gantry.hpp"
#include "varbo/task.hpp"

namespace varbo::transport {

struct TransportSettings {
  GantryParams gantry;
  double distance = 1.5;          ///< D, m: goal position of the cart and load
  double horizon = 6.0;           ///< T, s
  double dt = 0.01;               ///< RK4 step (and disturbance hold), s
  double load_mass_std = 0.3;     ///< per-episode std of m, kg
  double rod_length_std = 0.2;    ///< per-episode std of l, m
  double force_noise_std = 1.0;   ///< std of the force disturbance, held over each step, N
  double initial_swing_std = 0.1; ///< std of the load's initial angle, rad
  std::map<std::string, double> weights{{"tracking", 0.25}, {"sway", 2.0}, {"energy", 0.002}};
};

/// Raw (unweighted) cost integrals of one episode.
struct TransportRollout {
  double tracking = 0;  ///< ∫ (x_load − D)² dt, m² s
  double sway = 0;      ///< ∫ φ² dt, rad² s
  double energy = 0;    ///< ∫ F² dt, N² s
  GantryState final_state{};
};

/// Waypoint positions from θ's fractions a1..a3: w_i = w_{i−1} + a_i (D − w_{i−1}), w_0 = 0.
std::array<double, 3> waypoints(const Vec& theta, double distance);

/// Simulates one episode. θ = [a1, a2, a3, τ1, τ2, τ3, τ4]; `rng` draws m, l and the disturbances.
TransportRollout simulate_transport(const Vec& theta, const TransportSettings& s, Rng& rng);

class TransportTask final : public Task {
 public:
  explicit TransportTask(TransportSettings s) : s_(std::move(s)) {}
  Domain domain() const override;
  Evaluation evaluate(const Vec& theta, Rng& rng) override;
  std::optional<Vec> initial_point() const override;
  std::vector<std::string> component_names() const override { return {"tracking", "sway", "energy"}; }
  const TransportSettings& settings() const { return s_; }

 private:
  TransportSettings s_;
};

}  // namespace varbo::transport
