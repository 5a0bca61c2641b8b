#include "policy_task.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "varbo/errors.hpp"

namespace varbo::tasks {

FeaturePolicy::FeaturePolicy(Index n, Index m, const Vec& scale, std::uint64_t seed) : A_(m, n), c_(m) {
  if (m < 1) throw ConfigError("policy task: features must be at least 1");
  Rng rng(mix_seed(seed, 0xfea7));
  for (Index j = 0; j < m; ++j) {
    // Unit-variance pre-activations for states of typical size `scale`: tanh stays mostly in its smooth range.
    const Vec a = rng.normal_vec(n) / std::sqrt(static_cast<double>(n));
    A_.row(j) = a.cwiseQuotient(scale).transpose();
    c_(j) = rng.uniform(-0.5, 0.5);
  }
}

Vec FeaturePolicy::features(const Vec& s) const {
  Vec f(A_.rows() + 1);
  f.head(A_.rows()) = (A_ * s + c_).array().tanh().matrix();
  f(A_.rows()) = 1.0;
  return f;
}

PolicyTask::PolicyTask(std::unique_ptr<ControlSystem> system, PolicyTaskSettings s)
    : system_(std::move(system)), s_(s), policy_(system_->state_dim(), s.features, system_->state_scale(), s.seed) {
  if (!(s_.width > 0)) throw ConfigError("policy task: width must be positive");
  // The documented initial controller: an LQR gain K (poorly tuned on purpose, see lqr_q()), projected onto the
  // features by ridge regression of the saturated action clip(−K s) on states s ~ N(0, diag(scale²)).
  K_ = lqr_gain(*system_);
  const Index n = system_->state_dim(), d = policy_.parameters();
  const Index N = 20 * d;
  Rng rng(mix_seed(s_.seed, 0x1a9));
  Mat Phi(N, d);
  Vec target(N);
  const double umax = system_->force_limit();
  for (Index i = 0; i < N; ++i) {
    const Vec x = rng.normal_vec(n).cwiseProduct(system_->state_scale());
    Phi.row(i) = policy_.features(x).transpose();
    target(i) = std::clamp(-K_.dot(x), -umax, umax);
  }
  const double lambda = 1e-3 * static_cast<double>(N);
  const Mat G = Phi.transpose() * Phi + lambda * Mat::Identity(d, d);
  const Vec w = G.ldlt().solve(Phi.transpose() * target);
  projection_rms_ = std::sqrt((Phi * w - target).squaredNorm() / static_cast<double>(N));
  theta0_ = s_.initial_scale * w;
}

Domain PolicyTask::domain() const {
  Domain dom;
  dom.box.lower = theta0_.array() - s_.width;
  dom.box.upper = theta0_.array() + s_.width;
  for (Index j = 0; j + 1 < policy_.parameters(); ++j) dom.names.push_back(fmt::format("w{}", j + 1));
  dom.names.push_back("bias");
  return dom;
}

double PolicyTask::rollout(const Vec& theta, const Vec& s0) const {
  const ControlSystem& sys = *system_;
  const Index T = sys.steps();
  const double umax = sys.force_limit();
  Vec s = s0;
  double R = 0;
  for (Index t = 0; t < T; ++t) {
    const double u = std::clamp(policy_.action(theta, s), -umax, umax);
    s = rk4_step(sys, s, u, sys.dt());
    if (sys.failed(s)) break;  // the episode ends: no further reward (gym's termination)
    R += sys.reward(s) / static_cast<double>(T);  // Fröhlich 2021, section 5.2: r_t = (...)/T
  }
  return R;
}

double PolicyTask::expected_return(const Vec& theta, Index n, Rng& rng) const {
  double sum = 0;
  for (Index i = 0; i < n; ++i) sum += rollout(theta, system_->initial_state(rng));
  return sum / static_cast<double>(std::max<Index>(n, 1));
}

Evaluation PolicyTask::evaluate(const Vec& theta, Rng& rng) {
  if (theta.size() != policy_.parameters())
    throw InputError(fmt::format("policy task: theta has {} values, expected {}", theta.size(), policy_.parameters()));
  Evaluation e;
  const double R = expected_return(theta, s_.rollouts, rng);
  e.cost = -R;  // minimize cost = maximize the return
  return e;
}

}  // namespace varbo::tasks
