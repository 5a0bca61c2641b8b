// The ask / evaluate / tell loop of `varbo run`.
#include <fmt/format.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>

#include "run_writer.hpp"
#include "varbo/errors.hpp"
#include "varbo/loader.hpp"
#include "varbo/log.hpp"
#include "varbo/math.hpp"
#include "varbo/parallel.hpp"
#include "varbo/study.hpp"

namespace varbo {

namespace {
double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
std::string fmt_vec(const Vec& v) {
  std::string s = "[";
  for (Index i = 0; i < v.size(); ++i) s += fmt::format("{}{:.6g}", i ? ", " : "", v[i]);
  return s + "]";
}
}  // namespace

std::string RunSummary::report() const {
  std::string s = fmt::format("varbo run summary\n  output          {}\n  evaluations     {} ({} failed)\n", output,
                              evaluations, failed);
  if (best_theta) s += fmt::format("  best cost       {:.8g} at {}\n", best_cost, fmt_vec(*best_theta));
  if (recommended_theta) s += fmt::format("  recommended     {} (lowest posterior mean)\n", fmt_vec(*recommended_theta));
  if (simple_regret) s += fmt::format("  simple regret   {:.3e}\n", *simple_regret);
  s += fmt::format("  wall time       {:.2f} s\n", seconds);
  return s;
}

RunSummary run_study(const StudyConfig& study_in, const Registry& registry, const RunOverrides& ov) {
  StudyConfig study = study_in;
  if (ov.threads) study.threads = *ov.threads;
  if (ov.seed) study.seed = *ov.seed;
  if (ov.output) study.output = *ov.output;
  if (ov.budget) study.budget = *ov.budget;
  ThreadLimit limit(study.threads);
  const auto t_start = std::chrono::steady_clock::now();

  BuildContext tctx;
  tctx.seed = study.seed;
  std::unique_ptr<Task> task = registry.create<Task>(study.task, tctx);
  const Domain domain = task->domain();
  const Index d = domain.box.dim();
  if (d < 1) throw ConfigError(fmt::format("{}: task '{}' has no parameters", study.task.source.where(),
                                           study.task.info->name));
  if (!(domain.box.upper.array() > domain.box.lower.array()).all())
    throw ConfigError(fmt::format("{}: task '{}' has an empty domain (every upper bound must exceed its lower bound)",
                                  study.task.source.where(), study.task.info->name));

  BuildContext actx;
  actx.dim = d;
  actx.seed = study.seed;
  actx.budget = study.budget;
  std::optional<Vec> theta0 = study.initial_point ? study.initial_point : task->initial_point();
  if (theta0) {
    if (theta0->size() != d)
      study.source.child("initial_point")
          .fail(fmt::format("expected {} values (the task's dimension), got {}", d, theta0->size()));
    if (!domain.box.contains(*theta0))
      study.source.child("initial_point").fail("the initial point lies outside the task's domain");
    actx.initial_point = to_unit(*theta0, domain.box);
  }
  std::unique_ptr<Algorithm> algorithm = registry.create<Algorithm>(study.algorithm, actx);

  std::vector<std::string> names = domain.names;
  for (Index i = static_cast<Index>(names.size()); i < d; ++i) names.push_back(fmt::format("x{}", i + 1));
  Domain shown = domain;
  shown.names = names;
  RunWriter writer(study.output, study, shown, task->component_names());
  set_log_file(study.output + "/log.txt");
  log_info("run {}: task {}, algorithm {}, budget {}, seed {}, threads {}", study.output, study.task.info->name,
           study.algorithm.info->name, study.budget, study.seed,
           study.threads > 0 ? study.threads : hardware_threads());

  const std::optional<Optimum> optimum = task->optimum();
  RunSummary summary;
  summary.output = study.output;
  double best_noiseless = std::numeric_limits<double>::infinity();
  const Rng task_rng = Rng(study.seed).stream(0x7a5c);  // task noise: one stream per trial index
  Index last_snapshot = -1;

  while (summary.evaluations < study.budget) {
    std::vector<Suggestion> sugg = algorithm->ask(1);
    if (sugg.empty()) {
      log_info("the algorithm has nothing more to suggest; stopping after {} evaluations", summary.evaluations);
      break;
    }
    std::vector<Observation> obs;
    for (const Suggestion& s : sugg) {
      TrialRow row;
      row.index = summary.evaluations;
      row.phase = s.phase;
      Vec x = s.x;
      if (!Box::unit(d).contains(x, 1e-9)) {
        log_warn("algorithm suggested a point outside the unit cube; clamping it");
      }
      x = Box::unit(d).clamp(x);
      row.theta = from_unit(x, domain.box);
      row.fit_seconds = s.fit_seconds;
      row.acquisition_seconds = s.acquisition_seconds;
      Rng trng = task_rng.stream(static_cast<std::uint64_t>(row.index));
      const auto t0 = std::chrono::steady_clock::now();
      try {
        row.evaluation = task->evaluate(row.theta, trng);
      } catch (const std::exception& e) {
        row.evaluation = Evaluation{};
        row.evaluation.ok = false;
        row.evaluation.error = e.what();
      }
      row.evaluation_seconds = seconds_since(t0);
      if (row.evaluation.ok && !std::isfinite(row.evaluation.cost)) {
        row.evaluation.ok = false;
        row.evaluation.error = fmt::format("non-finite cost {}", row.evaluation.cost);
      }
      if (!row.evaluation.ok) {
        ++summary.failed;
        log_warn("trial {} failed: {}", row.index, row.evaluation.error);
      } else {
        if (!summary.best_theta || row.evaluation.cost < summary.best_cost) {
          summary.best_cost = row.evaluation.cost;
          summary.best_theta = row.theta;
        }
        const double nl =
            std::isnan(row.evaluation.noiseless_cost) ? row.evaluation.cost : row.evaluation.noiseless_cost;
        best_noiseless = std::min(best_noiseless, nl);
      }
      writer.trial(row);
      ++summary.evaluations;
      if (optimum && std::isfinite(best_noiseless)) summary.simple_regret = best_noiseless - optimum->cost;
      if (ov.progress) {
        std::string line = fmt::format("[{:>4}/{}] {:<10} cost {:>12.6g}  best {:>12.6g}", summary.evaluations,
                                       study.budget, s.phase, row.evaluation.ok ? row.evaluation.cost : NAN,
                                       summary.best_theta ? summary.best_cost : NAN);
        if (summary.simple_regret) line += fmt::format("  regret {:.2e}", *summary.simple_regret);
        line += fmt::format("  fit {:.3f}s acq {:.3f}s eval {:.3f}s", s.fit_seconds, s.acquisition_seconds,
                            row.evaluation_seconds);
        std::fprintf(stderr, "%s\n", line.c_str());
      }
      Observation o;
      o.x = x;
      o.cost = row.evaluation.cost;
      o.ok = row.evaluation.ok;
      o.components = row.evaluation.components;
      obs.push_back(std::move(o));
    }
    algorithm->tell(obs);
    if (auto snap = algorithm->snapshot(); snap && snap->iteration != last_snapshot) {
      writer.model(*snap);
      last_snapshot = snap->iteration;
    }
    summary.seconds = seconds_since(t_start);
    if (auto r = algorithm->recommendation()) summary.recommended_theta = from_unit(*r, domain.box);
    writer.summary(summary, shown, optimum);
  }
  summary.seconds = seconds_since(t_start);
  writer.summary(summary, shown, optimum);
  set_log_file("");
  return summary;
}

RunSummary run_study_file(const std::string& config_file, const RunOverrides& overrides) {
  ConfigNode root = ConfigNode::load_file(config_file);
  Registry registry;
  PluginLoader loader(registry);
  loader.load_default(plugin_paths_of(root));
  StudyConfig study = parse_study(root, registry);
  return run_study(study, registry, overrides);
}

}  // namespace varbo
