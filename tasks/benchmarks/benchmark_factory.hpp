#pragma once
// Declared options and the factory of the benchmark tasks (shared by the plugin and the tests).
#include <memory>
#include <vector>

#include "benchmark_functions.hpp"
#include "varbo/options.hpp"
#include "varbo/task.hpp"

namespace varbo::tasks {

/// `noise_std` and `bounds` for every benchmark, plus `dim` for the d-dimensional ones.
std::vector<OptionSpec> benchmark_options(const BenchmarkSpec& spec);
/// Builds the task from validated options; a bad `bounds` throws ConfigError naming its position.
std::unique_ptr<Task> make_benchmark_task(const BenchmarkSpec& spec, const Options& options);

}  // namespace varbo::tasks
