// libvarbo_tasks_policy.so: the cautious-BO tasks (Fröhlich et al. 2021): GP samples (section 5.1) and
// high-dimensional policy search on a cart-pole and a pendulum (section 5.2).
#include "cartpole.hpp"
#include "gp_sample.hpp"
#include "inverted_pendulum.hpp"
#include "policy_task.hpp"
#include "varbo/option_set.hpp"
#include "varbo/plugin.hpp"

using namespace varbo;

namespace {
using tasks::PolicyTaskSettings;
// The two policy tasks differ only in the default number of features.
struct CartPoleBalanceOptions {
  PolicyTaskSettings policy{129};
  Index steps = 0;  ///< episode length T; 0 = the task's default
};
struct PendulumStabilizeOptions {
  PolicyTaskSettings policy{64};
  Index steps = 0;
};

template <class S>
const OptionSet<S>& policy_options() {
  static const OptionSet<S> set{
      opt::integer("features", opt::nested(&S::policy, &PolicyTaskSettings::features),
                   "random tanh features m; the policy has d = m + 1 parameters (at most 10^4: features: 1e9 ended "
                   "in an internal error, bad_alloc)")
          .at_least(1)
          .at_most(1e4),
      opt::integer("seed", opt::nested(&S::policy, &PolicyTaskSettings::seed),
                   "seed of the fixed random features (episodes use the trial's stream)")
          .at_least(0),
      opt::real("width", opt::nested(&S::policy, &PolicyTaskSettings::width),
                "domain theta0 +- width per parameter (user units)")
          .above(0),
      opt::real("initial_scale", opt::nested(&S::policy, &PolicyTaskSettings::initial_scale),
                "theta0 = initial_scale * (LQR projected onto the features)"),
      opt::integer("steps", &S::steps, "episode length T (0 = the task's default)").at_least(0),
      opt::integer("rollouts", opt::nested(&S::policy, &PolicyTaskSettings::rollouts),
                   "episodes averaged per evaluation (10 estimates the expected return)")
          .at_least(1)};
  return set;
}

const OptionSet<tasks::GpSampleSettings>& gp_sample_options() {
  using S = tasks::GpSampleSettings;
  static const OptionSet<S> set{
      opt::integer("dim", &S::dim, "dimension d").at_least(1).at_most(1000),
      opt::integer("seed", &S::seed, "seed of the sample (features, optimum search, initial point)").at_least(0),
      opt::real("noise_std", &S::noise_std, "observation noise std (paper: 1e-3)").at_least(0),
      opt::integer("features", &S::features, "random Fourier features (at most 10^5: a dim × features matrix is held)")
          .at_least(1)
          .at_most(1e5),
      // 1e-300 made every feature overflow: every trial "non-finite cost -nan" (audit, session 44).
      opt::real("lengthscale", &S::lengthscale, "Matern lengthscale (user units; at least 1e-6: shorter ones overflow the features)").at_least(1e-6),
      opt::real("start_distance", &S::start_distance, "distance of the initial point from the optimum").at_least(0),
      opt::integer("search_points", &S::search_points, "dense-search points for the optimum (0 = 20000*d; at most 10^7)")
          .at_least(0)
          .at_most(1e7)};
  return set;
}
}  // namespace

VARBO_PLUGIN("tasks_policy", "0.1.0",
             "Cautious-BO tasks: GP samples (Froehlich 2021 sec. 5.1), cart-pole and pendulum policy search (sec. 5.2)") {
  registry.add(make_component<Task>(
      "gp_sample",
      "cost = -f, f a Matern-5/2 GP sample (sigma_f^2 = 1, l = 0.3) on [-1,1]^d conditioned on f(0) = 3, explicit "
      "via random Fourier features; optimum by dense search + L-BFGS; initial point at distance 0.3 from it",
      gp_sample_options().specs(),
      Factory<Task>([](const Options& o, const BuildContext&) {
        const tasks::GpSampleSettings s = gp_sample_options().read(o);
        return std::make_unique<tasks::GpSampleTask>(s);
      })));

  registry.add(make_component<Task>(
      "cartpole_balance",
      "gym CartPole-v1 dynamics, continuous force |u| <= 10 N, policy linear in m random tanh features (d = m+1, "
      "default 130); reward (1-|x|)/T per step (Froehlich 2021 sec. 5.2), T = 500, stop at |x| > 2.4 or 12 deg; "
      "cost = -return; theta0 = poorly tuned LQR projected on the features",
      policy_options<CartPoleBalanceOptions>().specs(), Factory<Task>([](const Options& o, const BuildContext&) {
        const auto s = policy_options<CartPoleBalanceOptions>().read(o);
        tasks::CartPoleParams p;
        if (s.steps > 0) p.steps = s.steps;
        return std::make_unique<tasks::PolicyTask>(std::make_unique<tasks::CartPole>(p), s.policy);
      })));

  registry.add(make_component<Task>(
      "pendulum_stabilize",
      "gym Pendulum dynamics (|u| <= 2 Nm), start near upright, policy linear in m random tanh features (d = m+1, "
      "default 65); reward (1-|alpha|/2deg)/T per step (Froehlich 2021 sec. 5.2), T = 200; cost = -return; "
      "theta0 = sluggish LQR projected on the features",
      policy_options<PendulumStabilizeOptions>().specs(), Factory<Task>([](const Options& o, const BuildContext&) {
        const auto s = policy_options<PendulumStabilizeOptions>().read(o);
        tasks::InvertedPendulumParams p;
        if (s.steps > 0) p.steps = s.steps;
        return std::make_unique<tasks::PolicyTask>(std::make_unique<tasks::InvertedPendulum>(p), s.policy);
      })));
}
