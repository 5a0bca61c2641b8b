#pragma once
// Each `varbo` sub-command lives in its own file and registers itself on the CLI11 app.
#include <CLI/CLI.hpp>
#include <functional>
#include <string>

namespace varbo::cli {
/// Adds a sub-command; the returned function runs it (returns the exit code).
using Runner = std::function<int()>;
Runner add_run(CLI::App& app);
Runner add_plugins(CLI::App& app);
Runner add_fit(CLI::App& app);
Runner add_rescore(CLI::App& app);
// Durable studies (cmd_study.cpp, cmd_status.cpp).
Runner add_study(CLI::App& app);
Runner add_suggest(CLI::App& app);
Runner add_observe(CLI::App& app);
Runner add_fail(CLI::App& app);
Runner add_abandon(CLI::App& app);
Runner add_retract(CLI::App& app);
/// Whether a `varbo run` drives the study at `location` now (it holds the study's run lock: the lock file's, or a
/// PostgreSQL study's advisory lock); a server that cannot be asked counts as yes (cmd_study.cpp).
bool run_is_live(const std::string& location);
Runner add_status(CLI::App& app);
Runner add_worker(CLI::App& app);  // cmd_worker.cpp
Runner add_export(CLI::App& app);
Runner add_select(CLI::App& app);
Runner add_plot(CLI::App& app);
Runner add_dashboard(CLI::App& app);  // cmd_dashboard.cpp, dashboard/
}  // namespace varbo::cli
