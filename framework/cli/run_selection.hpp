#pragma once
// The model work shared by `varbo select` and `varbo dashboard` (its κ slider): which surrogate a run's selection
// uses, how it is fitted, and how argmin E + κ·s is searched. One code path, so the dashboard's answer for a κ is
// the one `varbo select --kappa K` prints for the same trials.
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "varbo/registry.hpp"
#include "varbo/run_folder.hpp"
#include "varbo/select.hpp"

namespace varbo::cli {

/// `varbo select`'s default maximizer of −(E + κ·s).
inline constexpr const char* kSelectOptimizer = "{type: multistart, candidates: 2000, polish: 8}";

/// The surrogate named by `surrogate_arg` (inline YAML or a file; empty: the run's own). A run whose algorithm has
/// no surrogate and no `surrogate_arg` gets the default gp (an info line naming `where` says so).
ResolvedComponent selection_surrogate(const RunFolder& run, const Registry& registry, const std::string& surrogate_arg,
                                      const std::string& where);

struct FittedRunModel {
  ResolvedComponent spec;
  std::unique_ptr<Surrogate> model;
  FitReport report;
};

/// Builds `spec` for the run and fits it on the run's successful trials; `warm_start`: starting from the last
/// hyperparameters of model.yaml (`varbo select`'s default).
FittedRunModel fit_selection_model(const RunFolder& run, const Registry& registry, const ResolvedComponent& spec,
                                   std::uint64_t seed, bool warm_start);

/// The maximizer of −(E + κ·s) from inline YAML or a file (`flag` names it in messages).
std::unique_ptr<Optimizer> make_selection_optimizer(const RunFolder& run, const Registry& registry,
                                                    const std::string& text, const std::string& flag,
                                                    std::uint64_t seed);

/// For each κ, argmin E + κ·s over the whole domain (the evaluated points are starts too, so a minimum at a data
/// point is never missed), or among the evaluated θ only.
std::vector<RiskSelection> select_on_run(const Surrogate& model, const RunFolder& run, const std::vector<double>& kappas,
                                         const Optimizer& optimizer, std::uint64_t seed, bool among_evaluated);

/// The predicted mean lies below every observed cost by more than 2 predictive sd, or by more than a quarter of the
/// gap between the median and the lowest observed cost: a minimum the data do not support (a CMA-ES run's gp
/// predicted −6.4 ± 1.5 where no cost can be below −1, while its latent sd was 0.43 of σ_f; red team, session 26;
/// −9.05 ± 7.49 at a Branin box edge, costs ≥ 0.398, session 31).
bool below_observed(const RiskSelection& s, const RunFolder& run);
/// Either sign that E and s are extrapolations: far from the data (kExtrapolating) or below_observed.
bool extrapolating(const RiskSelection& s, const RunFolder& run);

/// One selection as `varbo select --json` prints it: kappa, ok, message and, when ok, theta (by name), params
/// (typed studies), mean, std, criterion, relative_latent_std, below_observed, extrapolating.
nlohmann::json selection_json(const RiskSelection& s, const RunFolder& run);

}  // namespace varbo::cli
