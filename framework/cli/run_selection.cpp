#include "run_selection.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <vector>

#include "component_arg.hpp"
#include "varbo/errors.hpp"
#include "varbo/log.hpp"

namespace varbo::cli {

ResolvedComponent selection_surrogate(const RunFolder& run, const Registry& registry, const std::string& surrogate_arg,
                                      const std::string& where) {
  if (!surrogate_arg.empty()) return registry.resolve(Kind::Surrogate, component_arg(surrogate_arg, "surrogate", "--surrogate"));
  if (const ResolvedComponent* own = run_surrogate_spec(run)) return *own;
  // A run of random, cma_es or rssgd (whose critic is a local model) has no surrogate of its own: the default gp,
  // said once, as `varbo plot` fits one (select refused where plot went on; red team, session 24).
  log_info("{}: the run's algorithm '{}' has no surrogate of its own; fitting the default gp (name another with "
           "--surrogate)",
           where, run.study.algorithm.info->name);
  return registry.resolve(Kind::Surrogate, ConfigNode::parse("gp", "<default surrogate>"));
}

FittedRunModel fit_selection_model(const RunFolder& run, const Registry& registry, const ResolvedComponent& spec,
                                   std::uint64_t seed, bool warm_start) {
  FittedRunModel f;
  f.spec = spec;
  f.model = make_run_surrogate(run, spec, registry, seed, warm_start);
  f.report = fit_run_surrogate(*f.model, run, seed);
  return f;
}

std::unique_ptr<Optimizer> make_selection_optimizer(const RunFolder& run, const Registry& registry,
                                                    const std::string& text, const std::string& flag,
                                                    std::uint64_t seed) {
  BuildContext octx;
  octx.dim = run.data.dim();
  octx.seed = seed;
  const ResolvedComponent spec = registry.resolve(Kind::Optimizer, component_arg(text, "acquisition_optimizer", flag));
  // The search keeps to the run's linear constraints and, once trials failed, away from them (select.hpp): an
  // optimizer that ignores constraints (ceres_lbfgs) answered outside them, worse than the evaluated points, with
  // ok: true (red team, session 24). Refused as `varbo run` refuses it.
  const bool constrained = run.failed.rows() > 0 || (run.space && run.space->has_constraints());
  const auto& provides = spec.info->provides;
  if (constrained && std::find(provides.begin(), provides.end(), "optimizer:constraints") == provides.end())
    throw ConfigError(fmt::format("{} {}: '{}' cannot keep to a constraint, and this run's selection has one ({}); "
                                  "use an optimizer that can, e.g. multistart (the default), sample_polish or "
                                  "random_search",
                                  flag, text, spec.info->full_name(),
                                  run.failed.rows() > 0 ? fmt::format("keep twice as far from the {} failed trials "
                                                                      "as from the nearest successful one",
                                                                      run.failed.rows())
                                                        : std::string("the search space's linear constraints")));
  return registry.create<Optimizer>(spec, octx);
}

std::vector<RiskSelection> select_on_run(const Surrogate& model, const RunFolder& run, const std::vector<double>& kappas,
                                         const Optimizer& optimizer, std::uint64_t seed, bool among_evaluated) {
  return among_evaluated
             ? select_among(model, run.domain, kappas, run.data.X, run.space)
             : select_policies(model, run.domain, kappas, optimizer, Rng(seed).stream(0x5e1), run.data.X, run.space,
                               run.failed);
}

bool below_observed(const RiskSelection& s, const RunFolder& run) {
  if (!s.ok || run.data.size() == 0) return false;
  const double lowest = run.data.y.minCoeff();
  // More than 2 sd below the lowest cost; or below it by a quarter of the gap between the median cost and the
  // lowest, whatever the sd: a mean extrapolated at the box's edge comes with a large sd of its own, and E = −9.05
  // (s = 7.49) on a Branin run whose costs are ≥ 0.398 went unflagged (red team, session 31).
  std::vector<double> y(run.data.y.data(), run.data.y.data() + run.data.y.size());
  std::nth_element(y.begin(), y.begin() + static_cast<std::ptrdiff_t>(y.size() / 2), y.end());
  const double median_gap = y[y.size() / 2] - lowest;
  return lowest - s.mean > 2.0 * s.std || (median_gap > 0 && lowest - s.mean > 0.25 * median_gap);
}

bool extrapolating(const RiskSelection& s, const RunFolder& run) {
  return s.ok && (s.relative_latent_std > kExtrapolating || below_observed(s, run));
}

nlohmann::json selection_json(const RiskSelection& s, const RunFolder& run) {
  nlohmann::json e = {{"kappa", s.kappa}, {"ok", s.ok}, {"message", s.message}};
  if (!s.ok) return e;
  nlohmann::json theta = nlohmann::json::object();
  for (Index i = 0; i < s.theta.size(); ++i) theta[run.names[static_cast<std::size_t>(i)]] = s.theta[i];
  e["theta"] = theta;
  if (run.space) e["params"] = nlohmann::json::parse(run.space->params(s.theta).to_json());
  e["mean"] = s.mean;
  e["std"] = s.std;
  e["criterion"] = s.criterion;
  e["relative_latent_std"] = s.relative_latent_std;
  e["below_observed"] = below_observed(s, run);
  e["extrapolating"] = extrapolating(s, run);
  return e;
}

}  // namespace varbo::cli
