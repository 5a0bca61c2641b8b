// libvarbo_tasks_noisy: BBOB-style test functions with noise models (moderate and severe), for benchmarking
// optimizers on noisy costs; see docs/noisy.md.
#include "noisy_factory.hpp"
#include "varbo/plugin.hpp"

VARBO_PLUGIN("tasks_noisy", "0.1.0",
             "Noisy benchmark suite: sphere, Rosenbrock, ellipsoid, step ellipsoid, Rastrigin, Schaffer F7, "
             "Griewank-Rosenbrock, Gallagher, Branin, Hartmann-6 with additive, multiplicative, uniform, Cauchy "
             "and input-dependent noise") {
  registry.add(varbo::make_component<varbo::Task>(
      "noisy",
      "a test function (function, dim, instance) observed through a noise model (noise, level); noise-free "
      "cost and optimum known",
      varbo::tasks::noisy::noisy_task_options(),
      varbo::Factory<varbo::Task>([](const varbo::Options& o, const varbo::BuildContext&) -> std::unique_ptr<varbo::Task> {
        return varbo::tasks::noisy::make_noisy_task(o);
      })));
}
