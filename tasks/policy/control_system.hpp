#pragma once
// A continuous-time single-input system for the policy-search tasks (Fröhlich et al. 2021, section 5.2):
// dynamics ṡ = f(s, u), a per-step reward, a failure test and a random initial state.
#include <string>
#include <vector>

#include "varbo/types.hpp"

namespace varbo::tasks {

class ControlSystem {
 public:
  virtual ~ControlSystem() = default;
  virtual Index state_dim() const = 0;
  virtual Vec derivative(const Vec& s, double u) const = 0;
  /// Immediate reward of the state reached after a step, before the 1/T normalization of section 5.2.
  virtual double reward(const Vec& s) const = 0;
  /// True when the episode must stop (no further reward is collected).
  virtual bool failed(const Vec& /*s*/) const { return false; }
  virtual Vec initial_state(Rng& rng) const = 0;
  /// Typical magnitude of each state variable: input scaling of the features and spread of the fit states.
  virtual Vec state_scale() const = 0;
  /// Mechanical energy (conserved when u = 0): a sanity check of the dynamics.
  virtual double energy(const Vec& s) const = 0;
  /// LQR weights of the documented initial controller (deliberately poorly tuned, see README.md).
  virtual Mat lqr_q() const = 0;
  virtual double lqr_r() const = 0;
  virtual double force_limit() const = 0;
  virtual double dt() const = 0;
  virtual Index steps() const = 0;
};

/// One classical RK4 step with constant input u.
Vec rk4_step(const ControlSystem& sys, const Vec& s, double u, double h);

/// Discrete-time LQR gain K (u = −K s) of the RK4-discretized system linearized at s = 0, u = 0 (central
/// differences), by iterating the discrete Riccati equation to convergence.
Vec lqr_gain(const ControlSystem& sys);

}  // namespace varbo::tasks
