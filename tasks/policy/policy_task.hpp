#pragma once
// Episodic policy search on a ControlSystem (Fröhlich et al. 2021, section 5.2). The policy is linear in fixed
// random features, u = clip(Σ_j w_j tanh(a_j·(s ⊘ scale) + c_j) + b, ±u_max), like the paper's "last layer of a
// fixed network": θ = (w_1..w_m, b), d = m + 1. The cost is minus the episode's return R = Σ_t r(s_t)/T.
#include <memory>

#include "control_system.hpp"
#include "varbo/task.hpp"

namespace varbo::tasks {

struct PolicyTaskSettings {
  Index features = 64;       ///< m hidden features (d = m + 1)
  std::uint64_t seed = 0;    ///< seed of the fixed features (not of the episodes)
  double width = 1.0;        ///< domain θ0 ± width per parameter (README.md: why not crbo.md's 10)
  double initial_scale = 1.0;///< θ0 = initial_scale · (LQR fit); < 1 degrades it further
  Index rollouts = 1;        ///< episodes averaged per evaluation (10: the paper's estimate of J(θ*))
};

class FeaturePolicy {
 public:
  FeaturePolicy(Index state_dim, Index features, const Vec& state_scale, std::uint64_t seed);
  Index parameters() const { return A_.rows() + 1; }
  Vec features(const Vec& s) const;  ///< (φ_1..φ_m, 1)
  double action(const Vec& theta, const Vec& s) const { return theta.dot(features(s)); }

 private:
  Mat A_;  ///< m × n (input scaling folded in)
  Vec c_;
};

class PolicyTask final : public Task {
 public:
  PolicyTask(std::unique_ptr<ControlSystem> system, PolicyTaskSettings s);
  Domain domain() const override;
  Evaluation evaluate(const Vec& theta, Rng& rng) override;
  std::optional<Vec> initial_point() const override { return theta0_; }

  /// The return of one episode from `s0` under θ (user units).
  double rollout(const Vec& theta, const Vec& s0) const;
  /// Mean return over `n` episodes with initial states from `rng`.
  double expected_return(const Vec& theta, Index n, Rng& rng) const;
  const ControlSystem& system() const { return *system_; }
  const Vec& lqr() const { return K_; }
  const FeaturePolicy& policy() const { return policy_; }
  /// RMS error of the projected θ0 against the LQR action on the fit states (before initial_scale).
  double projection_rms() const { return projection_rms_; }

 private:
  std::unique_ptr<ControlSystem> system_;
  PolicyTaskSettings s_;
  FeaturePolicy policy_;
  Vec K_;
  Vec theta0_;
  double projection_rms_ = 0;
};

}  // namespace varbo::tasks
