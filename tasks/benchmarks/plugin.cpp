// libvarbo_tasks_benchmarks: the standard test functions as tasks (Surjanovic & Bingham's VLSE).
#include "benchmark_factory.hpp"
#include "mixed_benchmarks.hpp"
#include "varbo/option_set.hpp"
#include "varbo/plugin.hpp"

VARBO_PLUGIN("tasks_benchmarks", "0.1.0",
             "Benchmark tasks: Branin, Hartmann-3/6, and d-dimensional Ackley, Rosenbrock, Levy, Styblinski-Tang") {
  for (const auto& spec : varbo::tasks::benchmark_specs()) {
    const varbo::tasks::BenchmarkSpec* s = &spec;  // static storage: outlives the registry
    registry.add(varbo::make_component<varbo::Task>(
        spec.name, spec.description, varbo::tasks::benchmark_options(spec),
        varbo::Factory<varbo::Task>([s](const varbo::Options& o, const varbo::BuildContext&) {
          return varbo::tasks::make_benchmark_task(*s, o);
        })));
  }
  // Typed search spaces (docs/search_space.md): integers, categories, a log scale, a linear constraint.
  for (const auto& b : varbo::tasks::mixed_benchmarks()) {
    const varbo::tasks::MixedBenchmark* m = &b;  // static storage
    registry.add(varbo::make_component<varbo::Task>(
        b.name, b.description,
        {varbo::opt::real("noise_std", 0.0, "std of additive Gaussian observation noise").at_least(0)},
        varbo::Factory<varbo::Task>([m](const varbo::Options& o, const varbo::BuildContext&) {
          return std::make_unique<varbo::tasks::MixedBenchmarkTask>(*m, o.real("noise_std"));
        })));
  }
}
