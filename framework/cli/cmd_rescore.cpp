// `varbo rescore RUN_DIR --weights energy=0.1 --kappa 0,2 [--continue N] [--rollouts M]`: re-weight a run's
// cost components, select policies offline by minimizing J̃ + κ r̃ in the local ε-ball around the learned
// policy (Kuindersma 2013, section 5.4.2), optionally continue with N risk-sensitive RSSGD steps.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "cli_parse.hpp"
#include "commands.hpp"
#include "varbo/host_task.hpp"
#include "varbo/errors.hpp"
#include "varbo/loader.hpp"
#include "varbo/math.hpp"
#include "varbo/numbers.hpp"
#include "varbo/parallel.hpp"
#include "varbo/run_folder.hpp"
#include "varbo/rescore.hpp"

namespace varbo::cli {

namespace {
std::string vec_text(const Vec& v) {
  std::string s = "[";
  for (Index i = 0; i < v.size(); ++i) s += fmt::format("{}{:.5g}", i ? ", " : "", v[i]);
  return s + "]";
}
}  // namespace

Runner add_rescore(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "rescore", "Re-weight a run's cost components and select policies offline for risk factors κ (J̃ + κ r̃)");
  struct Args {
    std::string run, weights, critic;
    std::vector<std::string> kappa;  ///< as given (decimal_items); default 0, 2
    double epsilon = -1;
    long long continue_steps = 0, rollouts = 0, seed = -1;
    int threads = 0;
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("run", a->run, "run folder (config.resolved.yaml, trials.csv with component columns)")
      ->required()
      ->check(run_folder());
  cmd->add_option("--weights", a->weights, "new weights, e.g. energy=0.1,tracking=1 (unlisted: the run's)");
  cmd->add_option("--kappa", a->kappa, "risk factors κ for the offline selections (default 0,2)")
      ->type_name("DECIMAL[,DECIMAL...]");
  cmd->add_option("--epsilon", a->epsilon, "radius of the local ball (unit cube; default: the run's rssgd ε)")
      ->check(decimal_number())
      ->check(positive_decimal("a radius in the unit cube"));
  cmd->add_option("--critic", a->critic, "local model as YAML, e.g. '{type: vhgp, restarts: 8}' (default: the run's)");
  cmd->add_option("--continue", a->continue_steps,
                  "then run N RSSGD steps from the selection of the last κ, at that κ (folder RUN/continue_k)")
      ->check(integer_in(0, 1000000));
  cmd->add_option("--rollouts", a->rollouts,
                  "evaluate the initial, learned and selected policies (and the continued one) with M fresh "
                  "rollouts under the new weights (new trials: not offline)")
      ->check(integer_in(0, 1000000));
  cmd->add_option("--seed", a->seed, "seed of the fit, the continuation and the rollouts (default: the run's)")
      ->check(integer_in(0, 9223372036854775807));
  cmd->add_option("--threads", a->threads, "worker threads (0 = all)")->check(integer_in(0, 2147483647));
  return [a]() {
    ThreadLimit limit(a->threads);
    Registry& registry = run_folder_registry(a->run);  // with the run's own plugins
    // A run of varbo.minimize has the task `python`: its domain is all an offline command needs (an evaluation, as
    // rescore's --rollouts, is a failed trial saying why). They refused such runs (red team, session 25).
    if (!registry.try_find(Kind::Task, "python")) add_host_python_task(registry);
    const ComponentRun run = load_component_run(a->run, registry);
    if (a->continue_steps > 0) check_continuable(run, registry);  // before the fit and the selection's output
    OfflineRequest request;
    request.weight_changes = parse_weight_list(a->weights, run.components);
    {
      // Every weight 0: every re-scored cost 0, and a model, a "noise selected" line and κ selections that mean
      // nothing, with exit 0 (audit, session 44).
      bool any = false;
      for (const auto& c : run.components) {
        const auto changed = request.weight_changes.find(c);
        const double w = changed != request.weight_changes.end() ? changed->second : run.weights.at(c);
        any = any || w != 0;
      }
      if (!any && !run.components.empty())
        throw InputError(fmt::format("--weights: every component's weight would be 0 ({}), so every re-scored cost "
                                     "is 0 and no policy can be preferred; give at least one component a nonzero "
                                     "weight",
                                     fmt::join(run.components, ", ")));
    }
    request.kappas = a->kappa.empty() ? std::vector<double>{0.0, 2.0} : decimal_items(a->kappa, "--kappa", "0,2");
    request.epsilon = a->epsilon;
    if (!a->critic.empty()) request.critic = registry.resolve(Kind::Surrogate, ConfigNode::parse(a->critic, "--critic"));
    if (a->seed >= 0) request.seed = static_cast<std::uint64_t>(a->seed);
    const OfflineAnswer answer = rescore_offline(run, request, registry);
    if (!answer.follows_convention)
      std::fprintf(stderr,
                   "varbo: warning: the recorded costs are not the weighted sums of the components (max difference "
                   "%.3g); the task does not follow the weights convention and re-scored costs may not compare\n",
                   answer.mismatch);
    const Weights& weights = answer.weights;
    const Vec& costs = answer.costs;
    const OfflineSelectionSettings& settings = answer.settings;
    const Vec& learned = answer.learned;
    const Vec& centre = answer.centre;

    std::printf("run %s: %ld successful trials, components %s\n", a->run.c_str(), static_cast<long>(costs.size()),
                fmt::format("{}", fmt::join(run.components, ", ")).c_str());
    std::string wtext;
    for (const auto& c : run.components)
      wtext += fmt::format("{}{}={} (was {})", wtext.empty() ? "" : ", ", c, weights.at(c), run.weights.at(c));
    std::printf("weights: %s\n", wtext.c_str());
    std::printf("re-scored costs: min %.6g mean %.6g max %.6g (recorded: min %.6g mean %.6g)\n", costs.minCoeff(),
                costs.mean(), costs.maxCoeff(), run.cost.minCoeff(), run.cost.mean());
    std::printf("learned policy (%s): %s\n", run.recommended ? "recommended" : "best", vec_text(learned).c_str());

    const LocalModel& model = answer.model;
    const std::vector<OfflineSelection>& sel = answer.selections;
    const Prediction at = model.critic->predict(centre, false);
    // The ε-ball holds at least min_local_points trials: the nearest ones beyond it are said as such ("3 trials within
    // eps = 1e-09" when none lay inside; audit, session 47).
    long within = 0;
    double farthest = 0;
    for (Index i = 0; i < model.data.size(); ++i) {
      const double dist = (model.data.X.row(i).transpose() - centre).norm();
      within += dist <= settings.radius;
      farthest = std::max(farthest, dist);
    }
    const long n = static_cast<long>(model.data.size());
    const std::string where =
        within == n ? fmt::format("{} trials within eps = {:.4g}", n, settings.radius)
                    : fmt::format("{} trials: {} within eps = {:.4g} and the nearest {} beyond it, up to {:.4g} away "
                                  "(min_local_points)",
                                  n, within, settings.radius, n - within, farthest);
    std::printf("local model: %s on %s; at the learned policy J~ %.6g r~ %.6g\n", settings.critic.info->name.c_str(),
                where.c_str(), at.mean, at.total_std());
    if (!model.fit.message.empty()) std::printf("  fit: %s\n", model.fit.message.c_str());
    for (const auto& s : sel) {
      std::printf("kappa %-6g J~ %-10.6g r~ %-10.6g J~+kappa*r~ %-10.6g theta %s\n", s.kappa, s.mean, s.std,
                  s.mean + s.kappa * s.std, vec_text(s.theta).c_str());
      // As `varbo select` says it: a selection where the local model extrapolates is not a prediction to trust.
      if (s.below_observed)
        std::printf("  (kappa %g: J~ is more than 2 r~ below every local cost: the model extrapolates)\n", s.kappa);
      if (s.far_from_data)
        std::printf("  (kappa %g: far from the data: the latent std is over half the signal std)\n", s.kappa);
    }

    std::optional<Vec> continued;
    if (a->continue_steps > 0) {
      if (sel.empty()) throw InputError("--continue needs at least one --kappa");
      int k = 1;
      while (std::filesystem::exists(fmt::format("{}/continue_{}", a->run, k))) ++k;
      const std::string folder = fmt::format("{}/continue_{}", a->run, k);
      const std::uint64_t seed = a->seed >= 0 ? static_cast<std::uint64_t>(a->seed) : run.study.seed + 1000 * k;
      const RunSummary s = continue_run(run, weights, costs, sel.back().theta, sel.back().kappa,
                                        a->continue_steps, folder, seed, registry);
      continued = s.recommended_theta;
      std::printf("continued %lld RSSGD steps at kappa %g in %s: theta %s\n", a->continue_steps, sel.back().kappa,
                  folder.c_str(), continued ? vec_text(*continued).c_str() : "(none)");
    }

    if (a->rollouts > 0) {
      // Fresh episodes under the NEW weights: the task built from the run's config with `weights` replaced.
      YAML::Node tnode = run.study.task.resolved();
      YAML::Node w(YAML::NodeType::Map);
      for (const auto& c : run.components) w[c] = yaml_scalar(weights.at(c));
      bool has_weights = false;
      for (const auto& o : run.study.task.info->options) has_weights = has_weights || o.name == "weights";
      if (has_weights) tnode["weights"] = w;
      YAML::Emitter em;
      em << YAML::Flow << tnode;
      BuildContext ctx;
      ctx.seed = run.study.seed;
      auto task = registry.create<Task>(std::string(em.c_str()), ctx);
      const std::uint64_t seed = (a->seed >= 0 ? static_cast<std::uint64_t>(a->seed) : run.study.seed) + 7919;
      std::printf("\n%lld fresh rollouts per policy under the new weights%s\n\n", a->rollouts,
                  has_weights ? "" : " (task has no weights option: its own cost)");
      std::printf("| policy | mean cost | std of cost |\n|---|---|---|\n");
      auto row = [&](const std::string& name, const Vec& th) {
        const PolicyStats p = evaluate_policy(*task, th, a->rollouts, seed);
        std::printf("| %s | %.4f | %.4f |%s\n", name.c_str(), p.mean, p.std,
                    p.failed ? fmt::format(" {} failed", p.failed).c_str() : "");
      };
      if (run.initial_point) row("initial policy", *run.initial_point);
      row("learned policy", learned);
      for (const auto& s : sel) row(fmt::format("offline kappa = {}", s.kappa), s.theta);
      if (continued) row(fmt::format("after {} RSSGD steps at kappa = {}", a->continue_steps, sel.back().kappa), *continued);
    }
    return 0;
  };
}

}  // namespace varbo::cli
