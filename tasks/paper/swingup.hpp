#pragma once
// The noisy pendulum swing-up of Kuindersma et al. 2013, section 5.2 (eq. 21); details and the choices
// the paper leaves open are in README.md in this folder.
#include "pendulum.hpp"
#include "varbo/options.hpp"
#include "varbo/task.hpp"

namespace varbo::tasks {

struct SwingupSettings {
  PendulumParams pendulum;
  double horizon = 3.5;           ///< T, s
  double goal_tolerance = 0.1;    ///< episode ends when α ≤ this, rad
  double angle_weight = 0.01;     ///< eq. (21)
  double effort_weight = 0.0001;  ///< eq. (21)
  double dt = 1e-3;               ///< RK4 step, s (steps are also cut at the switching times)
  double tau_mean = 4.0;          ///< τ_max ~ N(tau_mean, tau_std²), Nm
  double tau_std = 0.3;
  double t_max = 1.5;             ///< θ ∈ [0, t_max]²
};

struct SwingupResult {
  double cost = 0;         ///< angle_cost + effort_cost
  double angle_cost = 0;   ///< ∫ angle_weight·α dt
  double effort_cost = 0;  ///< ∫ effort_weight·u² dt
  bool reached = false;    ///< came within goal_tolerance of upright before T
  double t_end = 0;        ///< time the episode ended (T when not reached)
  int swings = 0;          ///< 1 + reversals of the angular velocity before the end
  PendulumState final_state;
};

/// Bang-bang torque of eq. (21): +τ on [0, t1], −τ on (t1, t1+t2], +τ after.
double bang_bang_torque(double t, double t1, double t2, double tau);

/// One episode with the given switching times and maximum torque (deterministic).
SwingupResult simulate_swingup(double t1, double t2, double tau_max, const SwingupSettings& s);

/// The settings named by the `pendulum_swingup` options (the plugin's and a run's config.resolved.yaml).
/// The options of `pendulum_swingup`, bound to SwingupSettings (whose initializers are the defaults).
std::vector<OptionSpec> swingup_options();
SwingupSettings swingup_settings(const Options& o);

class SwingupTask : public Task {
 public:
  explicit SwingupTask(SwingupSettings s) : s_(s) {}
  Domain domain() const override;  ///< [0, t_max]², names t1, t2
  /// Draws τ_max ~ N(tau_mean, tau_std²) from the trial's stream, then simulates.
  Evaluation evaluate(const Vec& theta, Rng& rng) override;
  std::vector<std::string> component_names() const override { return {"angle", "effort"}; }
  const SwingupSettings& settings() const { return s_; }

 private:
  SwingupSettings s_;
};

}  // namespace varbo::tasks
