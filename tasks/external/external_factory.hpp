#pragma once
// Declared options and the factory of the `external` task (shared by the plugin and the tests).
#include <memory>
#include <vector>

#include "varbo/options.hpp"
#include "varbo/task.hpp"

namespace varbo::tasks {

std::vector<OptionSpec> external_options();
/// Builds the task from validated options; inconsistent dimensions/bounds/names throw ConfigError
/// naming the key's position.
/// Without dim, lower/upper or names the task has no parameters until the study gives it its `parameters:`
/// (SpaceAware; docs/search_space.md); the study refuses it otherwise.
std::unique_ptr<Task> make_external_task(const Options& options);

}  // namespace varbo::tasks
