// libvarbo_tasks_paper: the synthetic tasks of Kuindersma et al. 2013, sections 5.1 and 5.2.
#include "swingup.hpp"
#include "two_minima.hpp"
#include "varbo/plugin.hpp"

using namespace varbo;

VARBO_PLUGIN("tasks_paper", "0.1.0",
             "Tasks of the variable-risk paper: 1-D two-minima cost (sec. 5.1), noisy pendulum swing-up (sec. 5.2)") {
  registry.add(make_component<Task>(
      "two_minima_1d",
      "1-D cost on [0,1], mean 0.5+0.4cos(4 pi t) (equal minima 0.1 at t=0.25 and 0.75), noise std "
      "0.02+0.2t^2 (low at 0.25, high at 0.75)",
      {opt::real("noise_scale", 1.0, "multiplies the noise std (0: noiseless)").at_least(0)},
      Factory<Task>([](const Options& o, const BuildContext&) {
        return std::make_unique<tasks::TwoMinimaTask>(o.real("noise_scale"));
      })));

  registry.add(make_component<Task>(
      "pendulum_swingup",
      "bang-bang pendulum swing-up, theta = switching times [t1, t2], cost = int 0.01 alpha + 0.0001 u^2 dt "
      "until within goal_tolerance of upright or T; tau_max ~ N(tau_mean, tau_std^2) per episode",
      tasks::swingup_options(),
      Factory<Task>([](const Options& o, const BuildContext&) {
        return std::make_unique<tasks::SwingupTask>(tasks::swingup_settings(o));
      })));
}
