#include "noisy_factory.hpp"

#include <fmt/format.h>

namespace varbo::tasks::noisy {

std::vector<OptionSpec> noisy_task_options() {
  return {
      opt::choice("function", "sphere", noisy_function_names(),
                  "test function (branin: d = 2 only; hartmann6: d = 6 only; rosenbrock, schaffer, "
                  "griewank_rosenbrock: d >= 2); see docs/noisy.md"),
      opt::integer("dim", 2, "number of dimensions (branin: 2, hartmann6: 6, where another value is an error)")
          .at_least(1).at_most(1000),
      opt::integer("instance", 1, "instance: fixes the shift x_opt, rotations and peaks (a seed of the problem)")
          .at_least(1).at_most(1000000),
      opt::choice("noise", "none", noise_model_names(), "observation-noise model; see docs/noisy.md for formulas"),
      opt::choice("level", "moderate", {"moderate", "severe"}, "noise level (BBOB's noisy-suite constants)"),
  };
}

std::unique_ptr<NoisyTask> make_noisy_task(const Options& options) {
  const NoisyFunctionSpec& spec = noisy_function_spec(options.str("function"));
  Index dim = static_cast<Index>(options.integer("dim"));
  if (spec.fixed_dim > 0) {
    if (options.given("dim") && dim != spec.fixed_dim)
      options.node("dim").fail(fmt::format("function '{}' is defined only for dim = {}, got {}", spec.name,
                                           spec.fixed_dim, dim));
    dim = spec.fixed_dim;
  } else if (dim < spec.min_dim) {
    options.node("dim").fail(fmt::format("function '{}' needs dim >= {}, got {}", spec.name, spec.min_dim, dim));
  }
  const Noise noise = Noise::make(noise_model_from_name(options.str("noise")),
                                  noise_level_from_name(options.str("level")), dim);
  return std::make_unique<NoisyTask>(spec, dim, options.integer("instance"), noise);
}

}  // namespace varbo::tasks::noisy
