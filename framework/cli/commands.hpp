#pragma once
// Each `varbo` sub-command lives in its own file and registers itself on the CLI11 app.
#include <CLI/CLI.hpp>
#include <functional>

namespace varbo::cli {
/// Adds a sub-command; the returned function runs it (returns the exit code).
using Runner = std::function<int()>;
Runner add_run(CLI::App& app);
Runner add_plugins(CLI::App& app);
Runner add_fit(CLI::App& app);
}  // namespace varbo::cli
