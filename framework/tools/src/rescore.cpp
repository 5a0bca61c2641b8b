// Offline re-weighting and risk re-selection of a finished run (Kuindersma 2013, section 5.4.2).
#include "varbo/rescore.hpp"

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <locale>
#include <nlohmann/json.hpp>

#include "varbo/continuation.hpp"
#include "varbo/csv.hpp"
#include "varbo/errors.hpp"
#include "varbo/regular_file.hpp"
#include "varbo/log.hpp"
#include "varbo/math.hpp"
#include "varbo/numbers.hpp"
#include "varbo/run_folder.hpp"

namespace fs = std::filesystem;

namespace varbo {

namespace {

double to_number(const std::string& s, const std::string& where) {
  if (s == "nan" || s.empty()) return std::nan("");
  const std::optional<double> v = parse_decimal(s);
  if (!v) throw InputError(fmt::format("{}: expected a decimal number, got '{}'", where, s));
  return *v;
}

std::optional<Vec> json_vec(const nlohmann::json& j, const char* key) {
  if (!j.contains(key) || !j[key].is_array()) return std::nullopt;
  Vec v(static_cast<Index>(j[key].size()));
  for (std::size_t i = 0; i < j[key].size(); ++i) v[static_cast<Index>(i)] = j[key][i].get<double>();
  return v;
}

bool declares_option(const ComponentInfo& info, const std::string& name) {
  for (const auto& o : info.options)
    if (o.name == name) return true;
  return false;
}

Weights run_weights(const StudyConfig& study, const std::vector<std::string>& components) {
  Weights w;
  for (const auto& c : components) w[c] = 1.0;
  if (!declares_option(*study.task.info, "weights") || !study.task.options.is_set("weights")) return w;
  const ConfigNode node = study.task.options.node("weights");
  if (!node.is_map()) node.fail("expected a map of component names to weights");
  for (const auto& key : node.keys()) {
    const ConfigNode v = node.child(key);
    if (!v.is_scalar()) v.fail("expected a number");
    w[key] = to_number(v.scalar(), v.where());
  }
  return w;
}

}  // namespace

ComponentRun component_run_from(const RunFolder& rf, const std::string& label) {
  if (rf.space)  // its model and steps would be in encoded coordinates
    throw InputError(fmt::format("{}: rescore does not handle studies with typed parameters or constraints yet "
                                 "(docs/search_space.md)",
                                 label));
  ComponentRun run;
  run.folder = rf.folder;
  run.study = rf.study;
  run.domain = rf.domain;
  run.initial_point = rf.initial_point;
  run.components = rf.components;
  if (run.components.empty()) throw InputError(fmt::format("{}: the run recorded no cost components", label));
  const Index d = run.domain.box.dim(), k = static_cast<Index>(run.components.size());
  std::vector<Index> keep;
  for (Index i = 0; i < rf.theta.rows(); ++i)
    if (rf.component_values.row(i).allFinite()) keep.push_back(i);
  const auto n = static_cast<Index>(keep.size());
  if (n == 0) throw InputError(fmt::format("{}: no successful trials with all components", label));
  if (n < rf.theta.rows())
    // They were left out in silence, the 5 best of 8 among them (red team, session 26).
    log_warn("{}: {} of {} successful trials lack a finite value of some cost component; re-scoring the other {}",
             label, rf.theta.rows() - n, rf.theta.rows(), n);
  run.theta.resize(n, d);
  run.unit.resize(n, d);
  run.values.resize(n, k);
  run.cost.resize(n);
  for (Index i = 0; i < n; ++i) {
    const Index r = keep[static_cast<std::size_t>(i)];
    run.theta.row(i) = rf.theta.row(r);
    run.unit.row(i) = to_unit(rf.theta.row(r).transpose(), run.domain.box).transpose();
    run.values.row(i) = rf.component_values.row(r);
    run.cost[i] = rf.cost[r];
  }
  run.weights = run_weights(run.study, run.components);
  return run;
}

void read_run_summary(ComponentRun& run, const std::string& summary) {
  std::error_code ec;
  if (!fs::exists(summary, ec)) return;
  require_regular_file(summary, "the run's summary, a JSON file");
  try {
    std::ifstream s(summary);
    const nlohmann::json j = nlohmann::json::parse(s);
    run.recommended = json_vec(j, "recommended_theta");
    run.best = json_vec(j, "best_theta");
  } catch (const nlohmann::json::exception& e) {
    throw InputError(fmt::format("{}: {}", summary, e.what()));
  }
  // A summary.json of another run (a study file's folder holds any) or a damaged one: a θ of the wrong size was
  // read past its end (SIGSEGV in the dashboard, made-up numbers), one outside the domain used as the centre.
  const Index d = run.domain.box.dim();
  for (auto* v : {&run.recommended, &run.best})
    if (*v && ((*v)->size() != d || !(*v)->allFinite() || !run.domain.box.contains(**v, 1e-9))) {
      log_warn("{}: {} has {} values{}, not a point of this run's {} parameters; ignored", summary,
               v == &run.recommended ? "recommended_theta" : "best_theta", (*v)->size(),
               (*v)->size() == d ? " outside the domain" : "", d);
      v->reset();
    }
}

ComponentRun load_component_run(const std::string& folder, const Registry& registry) {
  // The one reader of run folders (run_folder.hpp); here only the successful trials with every component.
  ComponentRun run = component_run_from(load_run_folder(folder, registry), folder + "/trials.csv");
  read_run_summary(run, folder + "/summary.json");
  return run;
}

OfflineAnswer rescore_offline(const ComponentRun& run, const OfflineRequest& request, const Registry& registry) {
  OfflineAnswer a;
  a.weights = merge_weights(run.weights, request.weight_changes);
  const Vec original = rescore_costs(run, run.weights);
  a.mismatch = (original - run.cost).cwiseAbs().maxCoeff();
  a.follows_convention = a.mismatch <= 1e-9 * (1 + run.cost.cwiseAbs().maxCoeff());
  a.costs = rescore_costs(run, a.weights);
  a.settings = offline_settings_from(run, registry);
  if (request.epsilon > 0) a.settings.radius = request.epsilon;
  if (request.critic) a.settings.critic = *request.critic;
  if (request.seed) a.settings.seed = *request.seed;
  a.learned_is_recommended = run.recommended.has_value();
  // Without summary.json (a study file, a worker's study) the best trial is the lowest recorded cost, as the docs
  // say ("else the best"): it was the first successful trial.
  Index lowest = 0;
  if (run.cost.size() > 0) run.cost.minCoeff(&lowest);
  a.learned = run.recommended ? *run.recommended : (run.best ? *run.best : Vec(run.theta.row(lowest).transpose()));
  a.centre = to_unit(a.learned, run.domain.box);
  a.selections = select_offline(run, a.costs, a.centre, request.kappas, a.settings, registry, &a.model);
  return a;
}

Weights parse_weight_list(const std::string& text, const std::vector<std::string>& components) {
  Weights w;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t end = std::min(text.find(',', start), text.size());
    const std::string item = text.substr(start, end - start);
    start = end + 1;
    if (item.empty()) {
      // An empty list (or a trailing comma) means no more; an empty item inside one (`a=1,,b=2`, `,,`) is a typo.
      if (end >= text.size()) break;
      throw InputError(fmt::format("--weights: an empty item in '{}'; expected name=value,name=value", text));
    }
    const std::size_t eq = item.find('=');
    if (eq == std::string::npos)
      throw InputError(fmt::format("--weights: expected name=value, got '{}'", item));
    const std::string name = item.substr(0, eq);
    bool known = false;
    for (const auto& c : components) known = known || c == name;
    if (!known)
      throw InputError(fmt::format("--weights: unknown component '{}' (the run recorded: {})", name,
                                   fmt::join(components, ", ")));
    const double v = to_number(item.substr(eq + 1), "--weights " + name);
    if (!std::isfinite(v) || v < 0) throw InputError(fmt::format("--weights: weight of '{}' must be finite and >= 0", name));
    if (w.count(name) != 0)
      throw InputError(fmt::format("--weights: '{}' given twice ({} and {}); each component once", name,
                                   w.at(name), v));
    w[name] = v;
    if (end >= text.size()) break;
  }
  return w;
}

Weights merge_weights(const Weights& base, const Weights& changes) {
  Weights w = base;
  for (const auto& [k, v] : changes) w[k] = v;
  return w;
}

Vec rescore_costs(const ComponentRun& run, const Weights& weights) {
  Vec out = Vec::Zero(run.values.rows());
  for (Index i = 0; i < run.values.rows(); ++i) {
    double c = 0;
    for (std::size_t k = 0; k < run.components.size(); ++k) {
      const auto it = weights.find(run.components[k]);
      c += (it == weights.end() ? 1.0 : it->second) * run.values(i, static_cast<Index>(k));  // eq. (23)
    }
    out[i] = c;
  }
  return out;
}

BallRegion::BallRegion(Vec centre, double radius) : centre_(std::move(centre)), radius_(radius) {
  const Index d = centre_.size();
  box_.lower = (centre_.array() - radius_).max(0.0).matrix();
  box_.upper = (centre_.array() + radius_).min(1.0).matrix();
  (void)d;
}

double BallRegion::constraint(const Vec& x, Vec* grad) const {
  if (grad) *grad = -2.0 * (x - centre_);
  return radius_ * radius_ - (x - centre_).squaredNorm();
}

Mat BallRegion::seeds() const { return centre_.transpose(); }

namespace {

/// The algorithm that continues `run`: its own when it offers RunContinuation, else the first loaded one that does.
const ComponentInfo& continuing_algorithm(const ComponentRun& run, const Registry& registry) {
  const ComponentInfo& own = *run.study.algorithm.info;
  if (own.extension<RunContinuation>()) return own;
  for (const ComponentInfo* c : registry.components(Kind::Algorithm))
    if (c->extension<RunContinuation>()) return *c;
  throw ConfigError("rescore: no loaded algorithm offers to continue a run (the RunContinuation extension of "
                    "varbo/continuation.hpp)");
}

}  // namespace

OfflineSelectionSettings offline_settings_from(const ComponentRun& run, const Registry& registry) {
  const ComponentInfo& alg = continuing_algorithm(run, registry);
  const bool own = &alg == run.study.algorithm.info;
  const LocalModelSpec m =
      alg.extension<RunContinuation>()->local_model(own ? &run.study.algorithm.options : nullptr, registry);
  OfflineSelectionSettings s;
  s.seed = run.study.seed;
  s.critic = m.critic;
  s.optimizer = m.optimizer;
  s.radius = m.radius;
  s.min_points = m.min_points;
  return s;
}

std::vector<OfflineSelection> select_offline(const ComponentRun& run, const Vec& costs, const Vec& centre,
                                             const std::vector<double>& kappas,
                                             const OfflineSelectionSettings& settings, const Registry& registry,
                                             LocalModel* model_out) {
  const Index d = run.unit.cols();
  // Weights that overflow the costs (energy=1e160) printed -nan and inf and exited 0; the models square costs.
  for (Index i = 0; i < costs.size(); ++i)
    if (!std::isfinite(costs[i]) || std::abs(costs[i]) > 1e150)
      throw InputError(fmt::format("rescore: a re-scored cost is {} (at most 1e150 in magnitude: the models square "
                                   "it); use smaller weights",
                                   costs[i]));
  Dataset all = Dataset::empty(d);
  for (Index i = 0; i < run.unit.rows(); ++i) all.add(run.unit.row(i).transpose(), costs[i]);
  // Local data: the ε-ball around the learned policy (at least min_points nearest).
  std::vector<std::pair<double, Index>> by_distance;
  for (Index i = 0; i < all.size(); ++i) by_distance.push_back({(all.X.row(i).transpose() - centre).norm(), i});
  std::sort(by_distance.begin(), by_distance.end());
  Dataset local = Dataset::empty(d);
  for (std::size_t k = 0; k < by_distance.size(); ++k)
    if (by_distance[k].first <= settings.radius || static_cast<Index>(k) < settings.min_points)
      local.add(all.X.row(by_distance[k].second).transpose(), all.y[by_distance[k].second]);
  BuildContext ctx;
  ctx.dim = d;
  ctx.seed = settings.seed;
  LocalModel m;
  m.critic = registry.create<Surrogate>(settings.critic, ctx);
  Rng rng = Rng(settings.seed).stream(0x5e1ec7);
  m.fit = m.critic->fit(local, rng);
  m.data = local;
  if (!m.critic->ready())
    throw NumericalError(fmt::format("rescore: the local model could not be fitted on {} trials: {}", local.size(),
                                     m.fit.message));
  if (!m.fit.ok) log_warn("rescore: the local model's fit: {}", m.fit.report());
  auto optimizer = registry.create<Optimizer>(settings.optimizer, ctx);
  const BallRegion ball(centre, settings.radius);
  std::vector<OfflineSelection> out;
  for (std::size_t k = 0; k < kappas.size(); ++k) {
    const RiskObjective f(*m.critic, kappas[k], d);
    Rng orng = rng.stream(1, k);
    OptimizeResult r = optimizer->maximize(f, ball, ball.seeds(), orng);
    Vec x = centre;
    if (r.x.size() == d && r.x.allFinite() && ball.contains(r.x, 1e-6)) {
      x = Box::unit(d).clamp(r.x);
    } else {
      log_warn("rescore: the search for kappa {} found no point in the ball ({}); keeping the learned policy",
               kappas[k], r.message);
    }
    // Never worse than the centre itself under the criterion (a local search can only improve on it).
    if (f.value(centre, nullptr) > f.value(x, nullptr)) x = centre;
    const Prediction p = m.critic->predict(x, false);
    OfflineSelection sel{kappas[k], x, from_unit(x, run.domain.box), p.mean, p.total_std()};
    sel.below_observed = local.y.minCoeff() - p.mean > 2.0 * p.total_std();
    sel.far_from_data = relative_latent_std(*m.critic, p) > kExtrapolating;
    out.push_back(std::move(sel));
  }
  if (model_out) *model_out = std::move(m);
  return out;
}

PolicyStats evaluate_policy(Task& task, const Vec& theta, Index rollouts, std::uint64_t seed) {
  PolicyStats s;
  std::vector<double> v;
  const Rng base = Rng(seed).stream(0xe7a1);
  for (Index i = 0; i < rollouts; ++i) {
    Rng r = base.stream(static_cast<std::uint64_t>(i));
    const Evaluation e = task.evaluate(theta, r);
    if (!e.ok || !std::isfinite(e.cost)) {
      ++s.failed;
      continue;
    }
    v.push_back(e.cost);
  }
  if (v.empty()) return s;
  const Eigen::Map<const Vec> m(v.data(), static_cast<Index>(v.size()));
  s.mean = m.mean();
  s.std = v.size() > 1 ? std::sqrt((m.array() - s.mean).square().sum() / static_cast<double>(v.size() - 1)) : 0.0;
  return s;
}

void check_continuable(const ComponentRun& run, const Registry& registry) {
  continuing_algorithm(run, registry);
  // Said before any fitting or printing, and for what it is: the continuation runs the task again, and only a task
  // that takes weights scores its new trials with the re-scored weights (an external task with components read
  // "a continued run cannot use new weights" although none were given, after the whole selection; audit, session 34).
  if (!declares_option(*run.study.task.info, "weights"))
    throw ConfigError(fmt::format(
        "rescore --continue runs the task again under the re-scored weights, and task '{}' has no `weights:` option "
        "to take them (its command computes the cost itself); re-score offline without --continue",
        run.study.task.info->name));
}

RunSummary continue_run(const ComponentRun& run, const Weights& weights, const Vec& costs, const Vec& start,
                        double kappa, Index steps, const std::string& folder, std::uint64_t seed,
                        const Registry& registry) {
  check_continuable(run, registry);
  const ComponentInfo& continuing = continuing_algorithm(run, registry);
  const bool own = &continuing == run.study.algorithm.info;
  fs::create_directories(folder);
  const std::string history = fs::absolute(folder + "/history.csv").string();
  {
    // The re-scored trials of the parent run, as the new run's critic data (θ in the unit cube).
    std::ofstream h(history);
    h.imbue(std::locale::classic());
    for (Index i = 0; i < run.unit.cols(); ++i) h << (i ? "," : "") << "x" << (i + 1);
    h << ",cost\n";
    for (Index r = 0; r < run.unit.rows(); ++r) {
      for (Index i = 0; i < run.unit.cols(); ++i) h << (i ? "," : "") << exact(run.unit(r, i));
      h << "," << exact(costs[r]) << "\n";
    }
  }
  YAML::Node cfg = run.study.resolved();
  YAML::Node w(YAML::NodeType::Map);
  // Numbers in the "C" locale whatever the host's (numbers.hpp).
  for (const auto& c : run.components) w[c] = yaml_scalar(weights.count(c) ? weights.at(c) : 1.0);
  cfg["task"]["weights"] = w;
  YAML::Node start_node(YAML::NodeType::Sequence);
  for (Index i = 0; i < start.size(); ++i) start_node.push_back(yaml_scalar(start[i]));
  cfg["initial_point"] = start_node;
  cfg["budget"] = yaml_scalar(steps);
  cfg["seed"] = yaml_scalar(seed);
  cfg["output"] = fs::absolute(folder).string();
  YAML::Node alg = own ? YAML::Node(cfg["algorithm"]) : YAML::Node(YAML::NodeType::Map);
  if (!own)  // the short name when it reaches this component, else the full one
    alg["type"] = registry.try_find(Kind::Algorithm, continuing.name) == &continuing ? continuing.name
                                                                                     : continuing.full_name();
  continuing.extension<RunContinuation>()->continue_from(alg, history, kappa);
  cfg["algorithm"] = alg;
  cfg["description"] = fmt::format("continuation of {} with new weights, kappa {}", run.folder, kappa);
  const std::string file = folder + "/study.yaml";
  {
    std::ofstream out(file);
    out.imbue(std::locale::classic());
    YAML::Emitter em;
    em << cfg;
    out << "# written by varbo rescore --continue\n" << em.c_str() << "\n";
  }
  const StudyConfig study = parse_study(ConfigNode::load_file(file), registry);
  RunOverrides ov;
  ov.progress = false;
  ov.overwrite = true;  // the continuation folder is rescore's own output, rewritten on every call
  return run_study(study, registry, ov);
}

}  // namespace varbo
