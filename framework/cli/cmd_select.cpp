// `varbo select RUN_DIR --kappa 2 --kappa -2`: variable risk after learning (Kuindersma 2013, section 3.2).
// Refits the run's surrogate on its successful trials and prints, for each κ, the θ minimizing E + κ·s,
// with the predicted mean and standard deviation. The task is never evaluated.
#include <fmt/format.h>

#include <algorithm>

#include <cstdio>
#include <nlohmann/json.hpp>

#include "cli_parse.hpp"
#include "commands.hpp"
#include "run_selection.hpp"
#include "varbo/csv.hpp"
#include "varbo/text.hpp"
#include "varbo/host_task.hpp"
#include "varbo/errors.hpp"
#include "varbo/loader.hpp"
#include "varbo/parallel.hpp"
#include "varbo/run_folder.hpp"
#include "varbo/select.hpp"

namespace varbo::cli {

namespace {
/// Characters of UTF-8 text (bytes that do not continue a sequence): the columns a terminal gives it.
std::size_t utf8_width(const std::string& text) {
  return static_cast<std::size_t>(std::count_if(text.begin(), text.end(), [](char c) {
    return (static_cast<unsigned char>(c) & 0xC0) != 0x80;
  }));
}
std::string theta_text(const Vec& theta, const SharedSpace& space) {
  std::string s = "[";
  for (Index i = 0; i < theta.size(); ++i)
    s += space && space->parameters()[static_cast<std::size_t>(i)].type != ParameterType::Real
             ? fmt::format("{}{}", i ? ", " : "", terminal_line(space->format_value(static_cast<std::size_t>(i), theta[i])))
             : fmt::format("{}{}", i ? ", " : "", exact(theta[i]));  // every digit: the θ a user deploys
  return s + "]";
}
}  // namespace

Runner add_select(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "select", "Pick risk-sensitive policies from a finished run: for each kappa, argmin E + kappa*s (no new trials)");
  struct Args {
    std::string run, surrogate, optimizer = kSelectOptimizer;
    std::vector<std::string> kappas;  ///< as given: decimal_items splits them
    bool from_config = false, json = false, among_evaluated = false;
    std::string seed = "1";
    int threads = 0;
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("run", a->run, "run folder written by `varbo run`")->required()->check(run_folder());
  cmd->add_option("--kappa", a->kappas,
                  "risk factor(s): > 0 risk-averse, < 0 risk-seeking, 0 neutral; repeat or comma-separate "
                  "(default: 2, 0, -2)")
      ->type_name("DECIMAL[,DECIMAL...]");
  CLI::Option* from_config = cmd->add_flag("--surrogate-from-config", a->from_config,
                "fit the surrogate of config.resolved.yaml from its defaults only (default: start the fit from "
                "the last hyperparameters in model.yaml)");
  // Both given, --surrogate won and the flag was ignored in silence (audit, session 44).
  cmd->add_option("--surrogate", a->surrogate,
                  "a different surrogate, whole: inline YAML ('gp', '{type: vhgp, noise_model: heteroscedastic}') or "
                  "a YAML file; the run's surrogate options are not merged in (config.resolved.yaml lists them)")
      ->excludes(from_config);
  cmd->add_option("--optimizer", a->optimizer, "maximizer of -(E + kappa*s): inline YAML or a YAML file")
      ->capture_default_str();
  cmd->add_option("--seed", a->seed, "random seed of the fit and the optimizer (same seed, same answer)")
      ->capture_default_str();
  cmd->add_option("--threads", a->threads, "worker threads (0 = all); the result does not depend on it")->check(integer_in(0, 2147483647));
  cmd->add_flag("--json", a->json, "print JSON instead of a table");
  cmd->add_flag("--among-evaluated", a->among_evaluated,
                "choose among the evaluated θ only (default: minimize over the whole domain, where a model far "
                "from the data extrapolates)");
  return [a]() {
    ThreadLimit limit(a->threads);
    const auto seed = static_cast<std::uint64_t>(integer_flag(a->seed, "--seed", 0));  // not saturated
    std::vector<double> kappas = a->kappas.empty() ? std::vector<double>{2.0, 0.0, -2.0}
                                                   : decimal_items(a->kappas, "--kappa", "2,0,-2");
    Registry& registry = run_folder_registry(a->run);  // with the run's own plugins
    // A run of varbo.minimize has the task `python`: its domain is all an offline command needs (an evaluation, as
    // rescore's --rollouts, is a failed trial saying why). They refused such runs (red team, session 25).
    if (!registry.try_find(Kind::Task, "python")) add_host_python_task(registry);
    const RunFolder run = load_run_folder(a->run, registry);

    const ResolvedComponent spec = selection_surrogate(run, registry, a->surrogate, a->run);
    const FittedRunModel fitted = fit_selection_model(run, registry, spec, seed, !a->from_config);
    const Surrogate* model = fitted.model.get();
    const FitReport& rep = fitted.report;
    const std::unique_ptr<Optimizer> optimizer = make_selection_optimizer(run, registry, a->optimizer, "--optimizer", seed);
    const std::vector<RiskSelection> sel = select_on_run(*model, run, kappas, *optimizer, seed, a->among_evaluated);

    if (a->json) {
      nlohmann::json j;
      j["run"] = a->run;
      j["surrogate"] = spec.info->full_name();
      j["trials"] = run.trials;
      j["n"] = run.data.size();
      j["seed"] = seed;
      j["fit"] = {{"ok", rep.ok}, {"objective", rep.objective}, {"log_likelihood", rep.log_likelihood},
                  {"message", rep.message}};
      for (const auto& h : model->hyperparameters()) j["hyperparameters"][h.name] = h.value;
      j["selections"] = nlohmann::json::array();
      for (const auto& s : sel) j["selections"].push_back(selection_json(s, run));
      std::printf("%s\n", j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
    } else {
      std::printf("varbo select %s: %s fitted on %lld of %lld trials (objective %.6g%s)\n", a->run.c_str(),
                  spec.info->full_name().c_str(), static_cast<long long>(run.data.size()),
                  static_cast<long long>(run.trials), rep.objective, rep.ok ? "" : ", FIT FAILED: previous model");
      // The fit's own note, e.g. the vhgp's "homoscedastic noise selected": κ then trades the mean against the
      // model's uncertainty only, and a user reading only the table could not know (red team, session 26).
      if (!rep.message.empty()) std::printf("  fit: %s\n", rep.message.c_str());
      std::printf("  parameters: %s\n", printable(join(run.names)).c_str());
      // The θ column as wide as its widest entry: a 2-D θ at full precision pushed E and s out of their columns
      // (audit, session 48).
      int width = 28;
      for (const auto& s : sel)
        if (s.ok) width = std::max(width, static_cast<int>(utf8_width(theta_text(s.theta, run.space))));
      std::printf("  %8s  %-*s %12s %12s %14s\n", "kappa", width, "theta", "mean E", "std s", "E + kappa*s");
      for (const auto& s : sel) {
        if (!s.ok) {
          std::printf("  %8.3g  no selection: %s\n", s.kappa, s.message.c_str());
          continue;
        }
        // An evaluated θ (--among-evaluated) is not far from the data: a high latent sd there is the model's
        // uncertainty (a noisy point), not an extrapolation.
        const char* flag = below_observed(s, run) ? "  (below every observed cost)"
                           : s.relative_latent_std > kExtrapolating
                               ? (a->among_evaluated ? "  (model uncertain here)" : "  (far from the data)")
                               : "";
        const std::string theta = theta_text(s.theta, run.space);
        // printf pads by bytes: a label's UTF-8 characters counted once each.
        const int pad = width + static_cast<int>(theta.size()) - static_cast<int>(utf8_width(theta));
        std::printf("  %8.3g  %-*s %12.6g %12.6g %14.6g%s\n", s.kappa, pad, theta.c_str(), s.mean, s.std, s.criterion,
                    flag);
      }
    }
    const double lowest = run.data.size() > 0 ? run.data.y.minCoeff() : 0.0;
    for (const auto& s : sel) {
      if (!s.ok) continue;
      const char* advice = a->among_evaluated ? "" : "; --among-evaluated chooses among the evaluated θ";
      if (below_observed(s, run))
        std::fprintf(stderr,
                     "varbo select: kappa %g chose a θ whose predicted mean %.6g lies below the lowest observed cost "
                     "%.6g by more than 2 sd (%.3g) or by a quarter of the costs' spread above it: the model "
                     "extrapolates there%s\n",
                     s.kappa, s.mean, lowest, s.std, advice);
      else if (s.relative_latent_std > kExtrapolating && !a->among_evaluated)
        std::fprintf(stderr,
                     "varbo select: kappa %g chose a θ far from the data (latent sd %.2f of the prior's): its E and s "
                     "are extrapolated%s\n",
                     s.kappa, s.relative_latent_std, advice);
    }
    for (const auto& s : sel)
      if (!s.ok) return 1;
    return 0;
  };
}

}  // namespace varbo::cli
