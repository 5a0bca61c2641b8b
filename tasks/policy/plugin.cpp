// libvarbo_tasks_policy.so: the cautious-BO tasks (Fröhlich et al. 2021): GP samples (section 5.1) and
// high-dimensional policy search on a cart-pole and a pendulum (section 5.2).
#include "cartpole.hpp"
#include "gp_sample.hpp"
#include "inverted_pendulum.hpp"
#include "policy_task.hpp"
#include "varbo/plugin.hpp"

using namespace varbo;

namespace {
std::vector<OptionSpec> policy_options(long features, double width) {
  return {opt::integer("features", features, "random tanh features m; the policy has d = m + 1 parameters")
              .at_least(1),
          opt::integer("seed", 0, "seed of the fixed random features (episodes use the trial's stream)").at_least(0),
          opt::real("width", width, "domain theta0 +- width per parameter (user units)").above(0),
          opt::real("initial_scale", 1.0, "theta0 = initial_scale * (LQR projected onto the features)"),
          opt::integer("steps", 0, "episode length T (0 = the task's default)").at_least(0),
          opt::integer("rollouts", 1, "episodes averaged per evaluation (10 estimates the expected return)")
              .at_least(1)};
}
tasks::PolicyTaskSettings policy_settings(const Options& o) {
  tasks::PolicyTaskSettings s;
  s.features = o.integer("features");
  s.seed = static_cast<std::uint64_t>(o.integer("seed"));
  s.width = o.real("width");
  s.initial_scale = o.real("initial_scale");
  s.rollouts = o.integer("rollouts");
  return s;
}
}  // namespace

VARBO_PLUGIN("tasks_policy", "0.1.0",
             "Cautious-BO tasks: GP samples (Froehlich 2021 sec. 5.1), cart-pole and pendulum policy search (sec. 5.2)") {
  registry.add(make_component<Task>(
      "gp_sample",
      "cost = -f, f a Matern-5/2 GP sample (sigma_f^2 = 1, l = 0.3) on [-1,1]^d conditioned on f(0) = 3, explicit "
      "via random Fourier features; optimum by dense search + L-BFGS; initial point at distance 0.3 from it",
      {opt::integer("dim", 2, "dimension d").at_least(1),
       opt::integer("seed", 0, "seed of the sample (features, optimum search, initial point)").at_least(0),
       opt::real("noise_std", 1e-3, "observation noise std (paper: 1e-3)").at_least(0),
       opt::integer("features", 1000, "random Fourier features").at_least(1),
       opt::real("lengthscale", 0.3, "Matern lengthscale (user units)").above(0),
       opt::real("start_distance", 0.3, "distance of the initial point from the optimum").at_least(0),
       opt::integer("search_points", 0, "dense-search points for the optimum (0 = 20000*d)").at_least(0)},
      Factory<Task>([](const Options& o, const BuildContext&) {
        tasks::GpSampleSettings s;
        s.dim = o.integer("dim");
        s.seed = static_cast<std::uint64_t>(o.integer("seed"));
        s.noise_std = o.real("noise_std");
        s.features = o.integer("features");
        s.lengthscale = o.real("lengthscale");
        s.start_distance = o.real("start_distance");
        s.search_points = o.integer("search_points");
        return std::make_unique<tasks::GpSampleTask>(s);
      })));

  registry.add(make_component<Task>(
      "cartpole_balance",
      "gym CartPole-v1 dynamics, continuous force |u| <= 10 N, policy linear in m random tanh features (d = m+1, "
      "default 130); reward (1-|x|)/T per step (Froehlich 2021 sec. 5.2), T = 500, stop at |x| > 2.4 or 12 deg; "
      "cost = -return; theta0 = poorly tuned LQR projected on the features",
      policy_options(129, 1.0), Factory<Task>([](const Options& o, const BuildContext&) {
        tasks::CartPoleParams p;
        if (o.integer("steps") > 0) p.steps = o.integer("steps");
        return std::make_unique<tasks::PolicyTask>(std::make_unique<tasks::CartPole>(p), policy_settings(o));
      })));

  registry.add(make_component<Task>(
      "pendulum_stabilize",
      "gym Pendulum dynamics (|u| <= 2 Nm), start near upright, policy linear in m random tanh features (d = m+1, "
      "default 65); reward (1-|alpha|/2deg)/T per step (Froehlich 2021 sec. 5.2), T = 200; cost = -return; "
      "theta0 = sluggish LQR projected on the features",
      policy_options(64, 1.0), Factory<Task>([](const Options& o, const BuildContext&) {
        tasks::InvertedPendulumParams p;
        if (o.integer("steps") > 0) p.steps = o.integer("steps");
        return std::make_unique<tasks::PolicyTask>(std::make_unique<tasks::InvertedPendulum>(p), policy_settings(o));
      })));
}
