#pragma once
// Reading a finished run folder back (config.resolved.yaml, trials.csv, model.yaml) to inspect or re-use its
// model without evaluating the task again: `varbo select`, `varbo plot`, `varbo rescore` and the C++ API. The one
// reader of run folders.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "varbo/registry.hpp"
#include "varbo/study.hpp"

namespace varbo {

struct RunFolder {
  std::string folder;
  StudyConfig study;                ///< parsed from config.resolved.yaml
  Domain domain;                    ///< from the task built from the resolved config (user units)
  SharedSpace space;                ///< typed parameters and constraints (docs/search_space.md); null: a box
  std::vector<std::string> names;   ///< parameter names (domain.names, x1.. when the task gives none)
  std::optional<Vec> initial_point; ///< the config's initial_point, else the task's (user units)
  Index trials = 0;                 ///< rows of trials.csv, failed ones included
  Mat theta;                        ///< successful trials, user units (rows)
  Vec cost;                         ///< their costs
  std::vector<std::string> phases;  ///< their phases ("initial", "ei", ...)
  Dataset data;                     ///< the same trials in the unit cube, as the algorithm saw them
  Mat failed;                       ///< failed trials (ok = 0) in the unit cube, rows; θ unreadable ones left out
  std::vector<std::string> components;  ///< trials.csv cost-component columns (between `ok` and the timings)
  Mat component_values;             ///< successful trials × components (NaN where a value is missing)
  std::vector<Hyperparameters> fits;  ///< model.yaml: hyperparameters after each fit (may be empty)
};

/// θ (user units) as the algorithm saw it: the search space's encoding, or the box mapped onto the unit cube
/// (clamped, as the runner does). One mapping for the successful and the failed trials, the CLI and the dashboard.
Vec unit_point(const RunFolder& run, const Vec& theta);

/// Reads `folder`; components are resolved against `registry`. Throws InputError/ConfigError naming the file.
RunFolder load_run_folder(const std::string& folder, const Registry& registry);

/// The registry to read `folder` with: the process's default one, plus the third-party plugins the run loaded
/// (`plugin_path:` of its config.resolved.yaml, relative to the folder) — one registry per set of paths, kept for
/// the process (plugins are never unloaded). Throws ConfigError when a listed path no longer exists.
Registry& run_folder_registry(const std::string& folder);

/// The surrogate the run's algorithm used (its `surrogate:` option, as resolved), or nullptr when the
/// algorithm has none (e.g. random search).
const ResolvedComponent* run_surrogate_spec(const RunFolder& run);

/// Builds a surrogate from `spec` for the run's dimension. With `warm_start`, the last hyperparameters in
/// model.yaml are set first when the surrogate is the run's own type (a fit then starts from them).
std::unique_ptr<Surrogate> make_run_surrogate(const RunFolder& run, const ResolvedComponent& spec,
                                              const Registry& registry, std::uint64_t seed, bool warm_start);

/// Fits `model` on the run's successful trials (unit cube). Throws NumericalError when the fit leaves no
/// usable model.
FitReport fit_run_surrogate(Surrogate& model, const RunFolder& run, std::uint64_t seed);

}  // namespace varbo
