#pragma once
// Declared options and the factory of the `noisy` task (shared by the plugin, the tests and bench/noisy).
#include <memory>
#include <vector>

#include "noisy_task.hpp"
#include "varbo/options.hpp"

namespace varbo::tasks::noisy {

/// function, dim, instance, noise, level.
std::vector<OptionSpec> noisy_task_options();
/// Builds the task from validated options; a dimension that does not suit the function throws ConfigError
/// naming the `dim` key.
std::unique_ptr<NoisyTask> make_noisy_task(const Options& options);

}  // namespace varbo::tasks::noisy
