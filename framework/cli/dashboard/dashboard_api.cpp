#include "dashboard_api.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "../slice_values.hpp"
#include "varbo/errors.hpp"
#include "varbo/math.hpp"
#include "varbo/numbers.hpp"
#include "varbo/rescore.hpp"
#include "varbo/text.hpp"

namespace varbo::cli {

namespace {

using json = nlohmann::json;

/// A request the API refuses, with its HTTP status. The message echoes parts of the request: kept printable and
/// bounded (safe_text), since what() ends at a NUL byte — `kappa=1%00x` answered "got '1" (audit, session 48).
struct RequestError : std::runtime_error {
  RequestError(int status, const std::string& message) : std::runtime_error(safe_text(message, 2048)), status(status) {}
  int status;
};

std::optional<std::string> query_value(const ApiQuery& query, const std::string& name) {
  const auto it = query.find(name);
  if (it == query.end()) return std::nullopt;
  // `?kappa=1&kappa=2` answered for the first only; a repeated parameter is refused, as the CLI refuses a key
  // given twice (lists are comma-separated: kappa=1,2).
  if (const auto n = query.count(name); n > 1)
    // The list form only where a list is taken (/api/rescore's kappa): /api/select then refused the form this
    // message suggested (red team, session 26).
    throw RequestError(400, fmt::format("query parameter '{}' is given {} times; give it once (where a list is "
                                        "taken, as /api/rescore's kappa, it is comma-separated: kappa=0,2)",
                                        name, n));
  return it->second;
}

double finite_number(const ApiQuery& query, const std::string& name) {
  const auto text = query_value(query, name);
  if (!text) throw RequestError(400, fmt::format("missing query parameter '{}' (a finite decimal number)", name));
  const std::optional<double> v = parse_decimal(*text);
  if (!v || !std::isfinite(*v))
    throw RequestError(400, fmt::format("query parameter '{}': expected a finite decimal number, got '{}'", name, *text));
  return *v;
}

long long integer(const ApiQuery& query, const std::string& name, long long fallback, long long lo, long long hi) {
  const auto text = query_value(query, name);
  if (!text) return fallback;
  // Digits only, as the CLI and YAML take integers: `since=1e1` was taken as 10 (red team, session 24).
  const bool digits = !text->empty() && text->find_first_not_of("0123456789", (*text)[0] == '-' ? 1 : 0) == std::string::npos &&
                      *text != "-";
  const std::optional<double> v = digits ? parse_decimal(*text) : std::nullopt;
  if (!v || !std::isfinite(*v) || *v != std::floor(*v) || *v < static_cast<double>(lo) || *v > static_cast<double>(hi))
    throw RequestError(400, fmt::format("query parameter '{}': expected an integer in [{}, {}], got '{}'", name, lo, hi,
                                        *text));
  return static_cast<long long>(*v);
}

bool flag(const ApiQuery& query, const std::string& name) {
  const auto text = query_value(query, name);
  if (!text) return false;
  if (*text == "1" || *text == "true" || text->empty()) return true;
  if (*text == "0" || *text == "false") return false;
  // A bare `?among_evaluated` (no value) is the flag set, as in HTML forms; the message says so.
  throw RequestError(400, fmt::format("query parameter '{}': expected 1, 0, true, false or no value (= true), got '{}'",
                                      name, *text));
}

json theta_json(const std::vector<std::string>& names, const Vec& theta) {
  json j = json::object();
  for (Index i = 0; i < theta.size() && static_cast<std::size_t>(i) < names.size(); ++i)
    j[names[static_cast<std::size_t>(i)]] = theta[i];
  return j;
}

json trial_json(const TrialRecord& t, const std::vector<std::string>& names, const SharedSpace& space) {
  json j = {{"id", t.id},
            {"state", state_name(t.state)},
            {"phase", t.phase},
            {"theta", theta_json(names, t.theta)},
            // Only a complete trial has a cost (a failed one is stored with a placeholder): null otherwise.
            {"cost", t.state == TrialState::Complete ? t.cost : std::nan("")},
            {"noiseless_cost", t.noiseless_cost},
            {"error", t.error},
            {"worker", t.worker},
            {"created_at", t.created_at},
            {"finished_at", t.finished_at},
            {"finish_seq", t.finish_seq},
            {"fit_seconds", t.fit_seconds},
            {"acquisition_seconds", t.acquisition_seconds},
            {"evaluation_seconds", t.evaluation_seconds}};
  if (space && t.theta.size() == static_cast<Index>(space->parameters().size()) && t.theta.allFinite()) {
    // Typed values as the user declared them, as summary.json, /api/model and Python give them: labels as
    // strings, integers and reals as numbers (they were all strings here; red team, session 30).
    j["params"] = json::parse(space->params(t.theta).to_json());
  }
  json comps = json::object();
  for (const auto& [name, v] : t.components) comps[name] = v;
  j["components"] = comps;
  return j;
}

/// The parameters as the page draws them: name, type, bounds, log, choices.
json parameters_json(const Study& study) {
  json out = json::array();
  const Domain& domain = study.domain();
  if (const SharedSpace& space = study.space()) {
    for (const auto& p : space->parameters()) {
      json entry = {{"name", p.name}, {"type", parameter_type_name(p.type)}, {"low", p.low}, {"high", p.high},
                    {"log", p.log}, {"choices", p.choices}};
      // A fixed parameter has no bounds of its own: its declaration's defaults (0, 1) were given as its bounds while
      // its value was 2 (audit, session 48). Its value instead, and bounds equal to it when it is a number.
      if (p.type == ParameterType::Fixed) {
        const bool label = !p.choices.empty();
        entry["value"] = label ? json(p.choices.front()) : json(p.value);
        entry["low"] = label ? json(nullptr) : json(p.value);
        entry["high"] = entry["low"];
      }
      out.push_back(std::move(entry));
    }
    return out;
  }
  for (Index i = 0; i < domain.box.dim(); ++i)
    out.push_back({{"name", static_cast<std::size_t>(i) < domain.names.size() ? domain.names[static_cast<std::size_t>(i)]
                                                                               : fmt::format("x{}", i + 1)},
                   {"type", "real"}, {"low", domain.box.lower[i]}, {"high", domain.box.upper[i]}, {"log", false},
                   {"choices", json::array()}});
  return out;
}

/// The encoded (unit-cube) point of an admissible θ, as load_run_folder maps trials.
Vec encode(const RunFolder& run, const Vec& theta) {
  return run.space ? run.space->encode(theta) : Vec(Box::unit(theta.size()).clamp(to_unit(theta, run.domain.box)));
}

/// One axis of a model view: the values of parameter `i` along a cut (user units) and how the page draws them.
struct Axis {
  std::string name, scale;  // scale: linear | log10 | category
  std::vector<double> values, coords;
  std::vector<std::string> labels;
};

Axis axis_of(const RunFolder& run, std::size_t i, int n) {
  Axis a;
  a.name = run.names[i];
  a.scale = "linear";
  if (run.space) {
    const Parameter& p = run.space->parameters()[i];
    a.values = slice_values(p, n);
    if (p.type == ParameterType::Categorical) {
      a.scale = "category";
      a.labels = p.choices;
    } else if (p.log) {
      a.scale = "log10";
    }
  } else {
    const double lo = run.domain.box.lower[static_cast<Index>(i)], hi = run.domain.box.upper[static_cast<Index>(i)];
    for (int k = 0; k < n; ++k) a.values.push_back(lo + (hi - lo) * k / std::max(1, n - 1));
  }
  for (const double v : a.values) a.coords.push_back(a.scale == "log10" ? std::log10(v) : v);
  return a;
}

json axis_json(const Axis& a) {
  return {{"name", a.name}, {"scale", a.scale}, {"values", a.values}, {"coords", a.coords}, {"labels", a.labels}};
}

std::size_t parameter_index(const RunFolder& run, const std::string& name, const std::string& key) {
  const auto it = std::find(run.names.begin(), run.names.end(), name);
  if (it == run.names.end())
    throw RequestError(400, fmt::format("query parameter '{}': the study has no parameter '{}' (it has {})", key, name,
                                        join(run.names)));
  return static_cast<std::size_t>(it - run.names.begin());
}

json fit_json(const DashboardModel& m) {
  json hp = json::object();
  for (const auto& h : m.fitted.model->hyperparameters()) hp[h.name] = h.value;
  return {{"surrogate", m.fitted.spec.info->full_name()},
          {"complete", m.complete},
          {"n", m.run.data.size()},
          {"trials", m.run.trials},
          {"seed", m.seed},
          {"fit", {{"ok", m.fitted.report.ok}, {"objective", m.fitted.report.objective},
                   {"log_likelihood", m.fitted.report.log_likelihood}, {"message", m.fitted.report.message},
                   {"seconds", m.fit_seconds},
                   // Conditioned: the last full fit's hyperparameters on the trials since (until the data grow by a
                   // quarter); full_fit_complete: the trials of that fit.
                   {"conditioned", m.full_fit_complete != m.complete},
                   {"full_fit_complete", m.full_fit_complete}}},
          {"hyperparameters", hp}};
}

json error_json(const std::string& message) { return {{"error", message}}; }

constexpr std::size_t kMaxRescoreKappas = 64;

}  // namespace

std::string json_text(const json& j) { return j.dump(-1, ' ', false, json::error_handler_t::replace); }

ApiResponse DashboardApi::get(const std::string& path, const ApiQuery& query) {
  try {
    if (!study_.present())
      return {404, json_text(error_json(fmt::format("{}: the study is gone (file removed?)", study_.shown())))};
    if (path == "/api/summary") return {200, summary()};
    if (path == "/api/trials") return {200, trials(query)};
    if (path == "/api/history") return {200, history()};
    if (path == "/api/model") return {200, model()};
    if (path == "/api/select") return {200, select(query)};
    if (path == "/api/slices") return {200, slices(query)};
    if (path == "/api/grid") return {200, grid(query)};
    if (path == "/api/region") return {200, region()};
    if (path == "/api/rescore") return {200, rescore(query)};
    return {404, json_text(error_json(fmt::format("no such resource '{}' (see docs/dashboard.md)", path)))};
  } catch (const RequestError& e) {
    return {e.status, json_text(error_json(e.what()))};
  } catch (const StoreConnectionError& e) {
    return {503, json_text(error_json(e.what()))};
  } catch (const InputError& e) {
    return {409, json_text(error_json(e.what()))};  // e.g. no model yet: fewer than 2 complete trials
  } catch (const std::exception& e) {
    return {500, json_text(error_json(e.what()))};
  }
}

std::string DashboardApi::summary() {
  const auto study = study_.study();
  const Study& s = *study;
  const auto all = study_.trials();
  json counts = {{"pending", 0}, {"complete", 0}, {"failed", 0}, {"abandoned", 0}};
  double fit = 0, acq = 0, eval = 0;
  std::optional<TrialRecord> best;
  std::vector<std::string> components;
  for (const auto& t : all) {
    counts[state_name(t.state)] = counts[state_name(t.state)].get<long long>() + 1;
    fit += t.fit_seconds;
    acq += t.acquisition_seconds;
    eval += t.evaluation_seconds;
    if (t.state == TrialState::Complete && (!best || t.cost < best->cost)) best = t;
    for (const auto& [name, v] : t.components)
      if (std::find(components.begin(), components.end(), name) == components.end()) components.push_back(name);
  }
  const long long finished = counts["complete"].get<long long>() + counts["failed"].get<long long>();
  const long long budget = static_cast<long long>(s.config().budget);
  const auto& names = s.domain().names;
  std::string surrogate;
  for (const auto& o : s.config().algorithm.info->options)
    if (o.name == "surrogate" && o.type == OptionType::Component && s.config().algorithm.options.is_set("surrogate"))
      surrogate = s.config().algorithm.options.component("surrogate").info->full_name();
  json j = {{"study", study_.shown()},
            {"task", s.config().task.info->name},
            {"algorithm", s.config().algorithm.info->name},
            {"surrogate", surrogate},
            {"seed", s.config().seed},
            {"budget", budget},
            {"counts", counts},
            {"finished", finished},
            {"remaining", std::max(0LL, budget - finished - counts["pending"].get<long long>())},
            {"names", names},
            {"parameters", parameters_json(s)},
            {"components", components},
            {"phase_seconds", {{"fit", fit}, {"acquisition", acq}, {"evaluation", eval}}},
            {"workers", study_.workers()},
            {"last_id", all.empty() ? -1 : all.back().id},
            {"server_time", unix_time()}};
  j["best"] = best ? json{{"id", best->id}, {"cost", best->cost}, {"theta", theta_json(names, best->theta)}}
                   : json(nullptr);
  // Typed values as declared (labels, integers), as /api/trials gives each trial's: the page showed the best θ's
  // category as its index ("solver=1") beside the recommended row's label (red team, session 46).
  if (best && s.space() && best->theta.size() == static_cast<Index>(s.space()->parameters().size()) &&
      best->theta.allFinite())
    j["best"]["params"] = json::parse(s.space()->params(best->theta).to_json());
  return json_text(j);
}

std::string DashboardApi::trials(const ApiQuery& query) {
  const long long since = integer(query, "since", -1, -1, std::numeric_limits<int>::max());
  const auto all = study_.trials();
  const auto study = study_.study();
  const Study& s = *study;
  json out = json::array();
  for (const auto& t : all)
    if (t.id > since) out.push_back(trial_json(t, s.domain().names, s.space()));
  return json_text({{"since", since}, {"total", all.size()}, {"last_id", all.empty() ? -1 : all.back().id},
                    {"trials", out}});
}

std::string DashboardApi::history() {
  const auto all = study_.trials();
  std::vector<const TrialRecord*> finished;
  for (const auto& t : all)
    if (t.finished()) finished.push_back(&t);
  std::sort(finished.begin(), finished.end(),
            [](const TrialRecord* a, const TrialRecord* b) { return a->finish_seq < b->finish_seq; });
  // `varbo run` records the regret of its recommendation per row when the task knows its optimum: from the
  // run's first row on, which need not be row 0 (results told before the run; red team, session 30). Rows
  // without one show NaN, as in trials.csv.
  bool with_regret = false;
  for (std::size_t row = finished.size(); study_.knows_optimum() && row-- > 0 && !with_regret;)
    with_regret = study_.regret_recommended(static_cast<std::int64_t>(row)).has_value();
  json points = json::array();
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t row = 0; row < finished.size(); ++row) {
    const TrialRecord& t = *finished[row];
    if (t.state == TrialState::Complete && t.cost < best) best = t.cost;
    json p = {{"seq", t.finish_seq}, {"id", t.id}, {"state", state_name(t.state)},
              {"cost", t.state == TrialState::Complete ? t.cost : std::nan("")},
              {"best", std::isfinite(best) ? json(best) : json(nullptr)}};
    if (with_regret) p["regret_recommended"] = study_.regret_recommended(static_cast<std::int64_t>(row)).value_or(std::nan(""));
    points.push_back(p);
  }
  return json_text({{"points", points}});
}

std::string DashboardApi::model() {
  const auto lock = study_.lock_model();
  const auto m = study_.model();
  json j = fit_json(*m);
  j["recommended"] = selection_json(m->recommended, m->run);
  return json_text(j);
}

std::string DashboardApi::select(const ApiQuery& query) {
  const double kappa = finite_number(query, "kappa");
  const bool among = flag(query, "among_evaluated");
  const auto lock = study_.lock_model();
  const auto m = study_.model();
  const RiskSelection sel = select_on_run(*m->fitted.model, m->run, {kappa}, *m->optimizer, m->seed, among).at(0);
  json j = fit_json(*m);
  j["among_evaluated"] = among;
  j["selection"] = selection_json(sel, m->run);
  return json_text(j);
}

std::string DashboardApi::slices(const ApiQuery& query) {
  const int n = static_cast<int>(integer(query, "n", 60, 2, 400));
  const auto lock = study_.lock_model();
  const auto m = study_.model();
  const RunFolder& run = m->run;
  const Vec base = m->recommended.theta;
  json out = json::array();
  for (std::size_t i = 0; i < run.names.size(); ++i) {
    if (run.space && run.space->parameters()[i].type == ParameterType::Fixed) continue;
    const Axis a = axis_of(run, i, n);
    std::vector<double> mean, lo, hi, data_x;
    for (const double v : a.values) {
      Vec t = base;
      t[static_cast<Index>(i)] = v;
      const Prediction p = m->fitted.model->predict(encode(run, t), false);
      mean.push_back(p.mean);
      lo.push_back(p.mean - 2 * p.total_std());
      hi.push_back(p.mean + 2 * p.total_std());
    }
    for (Index r = 0; r < run.theta.rows(); ++r) {
      const double v = run.theta(r, static_cast<Index>(i));
      data_x.push_back(a.scale == "log10" ? std::log10(v) : v);
    }
    json s = axis_json(a);
    s["mean"] = mean;
    s["lo"] = lo;
    s["hi"] = hi;
    s["data_x"] = data_x;
    s["data_y"] = std::vector<double>(run.cost.data(), run.cost.data() + run.cost.size());
    s["through"] = a.scale == "log10" ? std::log10(base[static_cast<Index>(i)]) : base[static_cast<Index>(i)];
    out.push_back(s);
  }
  return json_text({{"through", theta_json(run.names, base)}, {"complete", m->complete}, {"slices", out}});
}

std::string DashboardApi::grid(const ApiQuery& query) {
  const auto xname = query_value(query, "x");
  if (!xname) throw RequestError(400, "missing query parameter 'x' (a parameter name)");
  const auto yname = query_value(query, "y");
  const int n = static_cast<int>(integer(query, "n", yname ? 30 : 100, 2, yname ? 100 : 1000));
  const auto lock = study_.lock_model();
  const auto m = study_.model();
  const RunFolder& run = m->run;
  const std::size_t i = parameter_index(run, *xname, "x");
  const Vec base = m->recommended.theta;
  const Axis ax = axis_of(run, i, n);
  json j = {{"through", theta_json(run.names, base)}, {"complete", m->complete}, {"x", axis_json(ax)}};
  auto predict = [&](const Vec& t) { return m->fitted.model->predict(encode(run, t), false); };
  if (!yname) {
    std::vector<double> mean, sd;
    for (const double v : ax.values) {
      Vec t = base;
      t[static_cast<Index>(i)] = v;
      const Prediction p = predict(t);
      mean.push_back(p.mean);
      sd.push_back(p.total_std());
    }
    j["mean"] = mean;
    j["std"] = sd;
    // The trials along x with their costs (docs/dashboard.md listed data_x for the 1-D grid too; it had none).
    std::vector<double> dx, dc;
    for (Index r = 0; r < run.theta.rows(); ++r) {
      const double v = run.theta(r, static_cast<Index>(i));
      dx.push_back(ax.scale == "log10" ? std::log10(v) : v);
      dc.push_back(run.cost[r]);
    }
    j["data_x"] = dx;
    j["data_cost"] = dc;
    return json_text(j);
  }
  const std::size_t k = parameter_index(run, *yname, "y");
  if (k == i) throw RequestError(400, "query parameters 'x' and 'y' name the same parameter");
  const Axis ay = axis_of(run, k, n);
  json mean = json::array(), sd = json::array();
  for (const double vy : ay.values) {  // row r along y, column c along x
    std::vector<double> mr, sr;
    for (const double vx : ax.values) {
      Vec t = base;
      t[static_cast<Index>(i)] = vx;
      t[static_cast<Index>(k)] = vy;
      const Prediction p = predict(t);
      mr.push_back(p.mean);
      sr.push_back(p.total_std());
    }
    mean.push_back(mr);
    sd.push_back(sr);
  }
  std::vector<double> dx, dy;
  for (Index r = 0; r < run.theta.rows(); ++r) {
    dx.push_back(ax.scale == "log10" ? std::log10(run.theta(r, static_cast<Index>(i))) : run.theta(r, static_cast<Index>(i)));
    dy.push_back(ay.scale == "log10" ? std::log10(run.theta(r, static_cast<Index>(k))) : run.theta(r, static_cast<Index>(k)));
  }
  j["y"] = axis_json(ay);
  j["mean"] = mean;
  j["std"] = sd;
  j["data_x"] = dx;
  j["data_y"] = dy;
  return json_text(j);
}

std::string DashboardApi::region() {
  json out = json::array();
  for (const auto& s : study_.snapshots()) {
    if (s.snapshot.region_state.empty()) continue;
    out.push_back({{"after_trials", s.after_trials}, {"iteration", s.snapshot.iteration},
                   {"objective", s.snapshot.objective}, {"note", s.snapshot.note}, {"state", s.snapshot.region_state}});
  }
  return json_text({{"iterations", out}});
}

// RSSGD's re-weighting after learning (Kuindersma 2013, section 5.4.2; docs/rssgd.md): the trials' costs
// re-scored under new component weights (eq. 23), a local model fitted around the learned policy and J̃ + κ r̃
// minimized in its ε-ball for each κ: `varbo rescore RUN --weights ... --kappa ...` without its continuation
// or rollouts (no new trials), through the same library call so that the two agree.
std::string DashboardApi::rescore(const ApiQuery& query) {
  const auto all = study_.trials();
  const RunFolder view = study_.run_view(all, study_.snapshots());
  ComponentRun run = component_run_from(view, study_.shown());
  if (const auto summary = study_.summary_path()) read_run_summary(run, *summary);
  OfflineRequest request;
  try {
    request.weight_changes = parse_weight_list(query_value(query, "weights").value_or(""), run.components);
  } catch (const InputError& e) {
    throw RequestError(400, fmt::format("query parameter 'weights': {}", e.what()));
  }
  if (const auto text = query_value(query, "kappa")) {
    request.kappas.clear();
    std::size_t start = 0;
    while (start <= text->size()) {
      const std::size_t end = std::min(text->find(',', start), text->size());
      const std::string item = text->substr(start, end - start);
      const std::optional<double> v = parse_decimal(item);
      if (!v || !std::isfinite(*v))
        throw RequestError(400, fmt::format("query parameter 'kappa': expected finite decimal numbers separated by "
                                            "commas, got '{}'", *text));
      request.kappas.push_back(*v);
      // Each κ is one search of the local model: a 4 KB URL of 3000 κ held a thread for 10 s.
      if (request.kappas.size() > kMaxRescoreKappas)
        throw RequestError(400, fmt::format("query parameter 'kappa': at most {} values", kMaxRescoreKappas));
      start = end + 1;
    }
  }
  if (query_value(query, "epsilon")) {
    request.epsilon = finite_number(query, "epsilon");
    if (!(request.epsilon > 0)) throw RequestError(400, "query parameter 'epsilon': expected a positive number");
  }
  // One answer per request and data: the same key, the same trials → the cached answer (no refit).
  std::string key = fmt::format("{}|{}|{}|{}|", study_.generation(), run.cost.size(), request.epsilon,
                                fmt::join(request.kappas, ","));
  for (const auto& [c, w] : request.weight_changes) key += fmt::format("{}={};", c, w);
  {
    const std::lock_guard<std::mutex> lock(rescore_mutex_);
    if (const auto it = rescore_cache_.find(key); it != rescore_cache_.end()) return it->second;
  }
  const auto study = study_.study();
  const OfflineAnswer a = rescore_offline(run, request, study->registry());
  const auto& names = view.names;
  json weights = json::object(), was = json::object();
  for (const auto& c : run.components) {
    weights[c] = a.weights.at(c);
    was[c] = run.weights.at(c);
  }
  const Prediction at = a.model.critic->predict(a.centre, false);
  json selections = json::array();
  for (const auto& s : a.selections)
    selections.push_back({{"kappa", s.kappa}, {"theta", theta_json(names, s.theta)}, {"mean", s.mean},
                          {"std", s.std}, {"bound", s.mean + s.kappa * s.std}});
  json j = {{"components", run.components},
            {"weights", weights},
            {"run_weights", was},
            {"follows_weights_convention", a.follows_convention},
            {"trials", run.cost.size()},
            {"costs", {{"min", a.costs.minCoeff()}, {"mean", a.costs.mean()}, {"max", a.costs.maxCoeff()}}},
            {"learned", {{"from", a.learned_is_recommended ? "recommended" : "best"}, {"theta", theta_json(names, a.learned)}}},
            {"local_model", {{"surrogate", a.settings.critic.info->name}, {"n", a.model.data.size()},
                             {"epsilon", a.settings.radius}, {"seed", a.settings.seed},
                             {"mean_at_learned", at.mean}, {"std_at_learned", at.total_std()}}},
            {"selections", selections}};
  std::string body = json_text(j);
  const std::lock_guard<std::mutex> lock(rescore_mutex_);
  if (rescore_cache_.size() >= 32) rescore_cache_.clear();
  rescore_cache_[key] = body;
  return body;
}

}  // namespace varbo::cli
