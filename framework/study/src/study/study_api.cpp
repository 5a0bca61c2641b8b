// varbo::Study: ask/tell on a study store — creating and opening a study, asking for trials, recording results,
// abandoning, selecting. The algorithm is rebuilt from its latest saved state plus a replay of the trials finished
// since (study_rebuild.cpp); the state behind a Study is Study::Impl (study_impl.hpp).
#include "varbo/study_api.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <mutex>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "plugin_code.hpp"
#include "study_impl.hpp"
#include "stored_plugin_paths.hpp"
#include "varbo/csv.hpp"
#include "varbo/host_task.hpp"
#include "varbo/errors.hpp"
#include "varbo/loader.hpp"
#include "varbo/log.hpp"
#include "varbo/parallel.hpp"
#include "varbo/run_lock.hpp"
#include "varbo/math.hpp"
#include "varbo/numbers.hpp"
#include "varbo/search_space_config.hpp"
#include "varbo/space_wrappers.hpp"
#include "varbo/state.hpp"
#include "varbo/text.hpp"

namespace fs = std::filesystem;

namespace varbo {

using study_detail::emit;
using study_detail::log_cpu;
using study_detail::observation_of;

namespace {

std::vector<std::string> lines_of(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string l;
  while (std::getline(ss, l)) out.push_back(l);
  return out;
}

}  // namespace

std::string study_identity(const StudyConfig& c) {
  YAML::Node n(YAML::NodeType::Map);
  n["task"] = c.task.resolved();
  n["algorithm"] = c.algorithm.resolved();
  n["seed"] = yaml_scalar(c.seed);  // numbers in the "C" locale whatever the host's (numbers.hpp)
  if (c.initial_point) {
    YAML::Node v(YAML::NodeType::Sequence);
    for (Index i = 0; i < c.initial_point->size(); ++i) v.push_back(yaml_scalar((*c.initial_point)[i]));
    n["initial_point"] = v;
  }
  // Only when present: the identity of a study without them is unchanged.
  if (c.parameters) n["parameters"] = YAML::Clone(c.source.child("parameters").yaml());
  if (c.constraints.defined()) n["constraints"] = YAML::Clone(c.constraints.yaml());
  return emit(n);
}

namespace {
/// "task.upper" for line i of an emitted YAML block: the keys of the lines above it with less indentation. A
/// difference in a list showed as "stored '    - 1' vs now '    - 5'", naming no key (red team, session 28).
std::string key_path(const std::vector<std::string>& lines, std::size_t i) {
  auto indent = [](const std::string& l) { return l.find_first_not_of(' '); };
  std::vector<std::string> keys;
  std::size_t level = i < lines.size() ? indent(lines[i]) : 0;
  if (i < lines.size()) {
    const std::string& own = lines[i];
    const auto colon = own.find(':');
    if (colon != std::string::npos && own.compare(level, 2, "- ") != 0) keys.push_back(own.substr(level, colon - level));
  }
  for (std::size_t j = std::min(i, lines.size()); j-- > 0 && level > 0;) {
    const std::size_t in = indent(lines[j]);
    if (in == std::string::npos || in >= level) continue;
    const auto colon = lines[j].find(':');
    if (colon == std::string::npos) continue;
    std::string key = lines[j].substr(in, colon - in);
    if (key.rfind("- ", 0) == 0) {
      // An item of a list: named by its `name:` where it has one ("parameters[solver].choices"; it read
      // "parameters.name.choices", naming no parameter: red team, session 46), else by its first key as before.
      key = key.substr(2);
      for (std::size_t m = j; m < lines.size() && (m == j || (indent(lines[m]) != std::string::npos &&
                                                               indent(lines[m]) > in));
           ++m) {
        const std::size_t at = m == j ? in + 2 : indent(lines[m]);
        if (m != j && at != in + 2) continue;
        if (lines[m].compare(at, 6, "name: ") == 0) {
          key = "[" + lines[m].substr(at + 6) + "]";
          break;
        }
      }
    }
    keys.insert(keys.begin(), key);
    level = in;
  }
  std::string out;
  for (const auto& k : keys) out += (out.empty() || k.front() == '[' ? "" : ".") + k;
  return out;
}
}  // namespace

namespace {
void block_style(YAML::Node n) {
  if (n.IsMap() || n.IsSequence()) n.SetStyle(YAML::EmitterStyle::Block);
  if (n.IsMap())
    for (auto kv : n) block_style(kv.second);
  else if (n.IsSequence())
    for (auto item : n) block_style(item);
}

/// An emitted identity with every list and map in block style. The identity keeps `parameters:` as the source
/// wrote it (a stored identity must stay what it was), so a study created with flow entries (`- {name: mode, ...}`)
/// and read back from its run folder's config.resolved.yaml (block style) differed in text only: `varbo select`
/// warned of an edited file on every typed run (red team, session 31).
std::string canonical_identity(const std::string& text) {
  try {
    YAML::Node n = YAML::Load(text);
    block_style(n);
    return emit(n);
  } catch (const YAML::Exception&) {
    return text;
  }
}
}  // namespace

bool study_detail::same_identity(const std::string& stored, const std::string& now) {
  return stored == now || canonical_identity(stored) == canonical_identity(now);
}

/// The first line where two texts differ, as "at task.upper: stored 'a' vs now 'b'" (in block style: a list
/// written in flow style is one line, and differs as a whole).
std::string study_detail::first_difference(const std::string& stored_text, const std::string& now_text) {
  const std::string stored = canonical_identity(stored_text), now = canonical_identity(now_text);
  const auto a = lines_of(stored), b = lines_of(now);
  std::size_t i = 0;
  while (i < a.size() && i < b.size() && a[i] == b[i]) ++i;
  // The key of the line that differs in the text where it is: a line only in `now` (an option a plugin added
  // since) was given the path of the stored line after it ("at algorithm.acquisition" for a new
  // algorithm.surrogate.as_noise; red team, session 30); a line only in `stored` keeps the stored path.
  const bool removed = i < a.size() && (i >= b.size() || (i + 1 < a.size() && a[i + 1] == b[i]));
  const std::string where = removed ? key_path(a, i) : i < b.size() ? key_path(b, i) : key_path(a, i);
  return fmt::format("{}stored '{}' vs now '{}'", where.empty() ? "" : "at " + where + ": ",
                     i < a.size() ? a[i] : "<end>", i < b.size() ? b[i] : "<end>");
}
using study_detail::first_difference;

bool study_detail::adopt_current_resolution(const std::string& store_path, const StudyConfig& config,
                                            const Registry& registry) {
  std::unique_ptr<StudyStore> store = open_store(store_path);
  const std::string identity = study_identity(config);
  const auto stored = store->meta(store_key::kIdentity);
  if (!stored || study_detail::same_identity(*stored, identity)) return false;
  // Only a difference of resolution is adopted: the stored configuration, resolved by this version, must be the
  // configuration given. One the user changed (another seed, budget aside, another algorithm) is still refused by
  // Study::attach as another study's; adopting it would continue the trials of one configuration with another's.
  const auto text = store->meta(store_key::kConfig);
  if (!text) return false;
  try {
    const StudyConfig resolved_now =
        parse_study(ConfigNode::parse(*text, store_path + ConfigNode::kStoredSuffix), registry);
    if (study_identity(resolved_now) != identity) return false;
  } catch (const std::exception& e) {  // stored by a version whose options this one no longer takes
    log_debug("{}: the stored configuration does not parse with the plugins loaded now: {}", store_path, e.what());
    return false;
  }
  log_warn("{}: the stored configuration resolves differently with the plugins loaded now (an option added or a "
           "default changed since the study was created; first difference: {}); continuing with it as resolved "
           "now, which the study records",
           store_path, first_difference(*stored, identity));
  store->set_meta(store_key::kConfig, "# varbo study configuration (resolved)\n" + emit(config.resolved()));
  store->set_meta(store_key::kIdentity, identity);
  return true;
}

Vec study_detail::recommended_theta(const Vec& r, const std::vector<TrialRecord>& trials, const SearchSpace* space,
                                    const Box& box) {
  const Vec x = space ? space->admissible(r) : Vec(Box::unit(r.size()).clamp(r));
  for (const TrialRecord& t : trials)
    if (t.state == TrialState::Complete && t.x.size() == x.size() && (t.x - x).lpNorm<Eigen::Infinity>() <= 1e-12)
      return t.theta;
  return space ? space->decode(x) : from_unit(r, box);
}

bool study_detail::usable_recommendation(const Vec& r, Index dim, const std::string& algorithm, bool say) {
  if (r.size() == dim && r.allFinite()) {
    if (Box::unit(dim).contains(r, 1e-9)) return true;
    // [17, 17] for a task box of [-1, 1] was reported as the recommendation, with its regret (red team, session 28).
    if (say)
      log_warn("algorithm '{}' recommended a point outside the unit cube (a coordinate {} is not in [0, 1]); no "
               "recommendation",
               algorithm, exact(r.minCoeff() < 0 ? r.minCoeff() : r.maxCoeff()));
    return false;
  }
  if (say)
    log_warn("algorithm '{}' recommended {}; no recommendation", algorithm,
             r.size() != dim ? fmt::format("a point of dimension {} (expected {})", r.size(), dim)
                             : std::string("a point with a non-finite coordinate"));
  return false;
}

Study::Study(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {
  if (impl_ && impl_->store) impl_->note_file();
}
Study::Impl& Study::live() const {
  // A moved-from Study (its Impl moved away) crashed on any call (red team, session 27).
  if (!impl_) throw std::logic_error("varbo::Study used after it was moved from");
  return *impl_;
}
Study::Study(Study&&) noexcept = default;
Study& Study::operator=(Study&&) noexcept = default;
Study::~Study() = default;

namespace {
/// A real parameter over several decades without `log: true` (a learning rate in [1e-7, 1]): the search spends its
/// trials at the top decades and 6 of 15 trials sat at the lower bound (red team, session 30). Said when the study
/// is made, once per parameter.
void warn_wide_linear_bounds(const Study::Impl& impl) {
  const Box& box = impl.domain.box;
  for (Index i = 0; i < box.dim(); ++i) {
    const auto& params = impl.space ? impl.space->parameters() : std::vector<Parameter>{};
    if (impl.space && (static_cast<std::size_t>(i) >= params.size() ||
                       params[static_cast<std::size_t>(i)].type != ParameterType::Real ||
                       params[static_cast<std::size_t>(i)].log))
      continue;
    const double lo = impl.space ? params[static_cast<std::size_t>(i)].low : box.lower(i);
    const double hi = impl.space ? params[static_cast<std::size_t>(i)].high : box.upper(i);
    const std::string name = i < static_cast<Index>(impl.domain.names.size())
                                 ? printable(impl.domain.names[static_cast<std::size_t>(i)])
                                 : std::to_string(i + 1);
    if (lo > 0 && hi / lo >= 1e3)
      log_warn("parameter {} spans [{}, {}], {:.0f} decades, on a linear scale: most trials land in the top decade; "
               "if its scale is logarithmic (a rate, a gain), declare it `{{name: {}, type: real, low: {}, high: {}, "
               "log: true}}` in `parameters:`",
               name, exact(lo), exact(hi), std::log10(hi / lo), name, exact(lo), exact(hi));
  }
}

void create_study_store(Study::Impl& impl, const std::string& store_path) {
  impl.make_algorithm();  // surface configuration errors before any file is written
  warn_wide_linear_bounds(impl);
  impl.store = create_store(store_path, impl.meta_entries(study_identity(impl.config), store_path));
  impl.address = store_path;
}
}  // namespace

Study Study::create(const std::string& store_path, const std::string& config_file) {
  const ConfigNode root = ConfigNode::load_file(config_file);
  auto impl = impl_with_plugins(plugin_paths_of(root));
  add_host_python_task(*impl->own_registry);  // a domain evaluated elsewhere (study_plugins.cpp, shared_registry)
  impl->init(parse_study(root, *impl->own_registry), *impl->own_registry);
  create_study_store(*impl, store_path);
  return Study(std::move(impl));
}

Study Study::create_from_yaml(const std::string& store_path, const std::string& yaml, const std::string& name) {
  const ConfigNode root = ConfigNode::parse(yaml, name);
  auto impl = impl_with_plugins(plugin_paths_of(root));
  add_host_python_task(*impl->own_registry);
  impl->init(parse_study(root, *impl->own_registry), *impl->own_registry);
  create_study_store(*impl, store_path);
  return Study(std::move(impl));
}

namespace {
/// Study::open(path) passes this very object: no components of the caller's, so the process's shared registry.
const std::function<void(Registry&)> kNoComponents = [](Registry&) {};
}  // namespace

Study Study::open(const std::string& store_path) { return open(store_path, kNoComponents); }

Study Study::open(const std::string& store_path, const std::function<void(Registry&)>& add_components) {
  log_cpu("opening (process start, libraries, command line)");
  std::unique_ptr<StudyStore> store = open_store(store_path);
  log_cpu("store opened");
  const auto text = store->meta(store_key::kConfig);
  if (!text) throw InputError(fmt::format("{}: the study store holds no configuration (corrupt store?)", store_path));
  const std::vector<std::string> paths = study_detail::stored_plugin_paths(*store, store_path);
  std::unique_ptr<Impl> impl;
  const Registry* registry = nullptr;
  const bool shared = &add_components == &kNoComponents;
  if (!shared) {  // components of the caller's own: a registry of this study's own
    impl = impl_with_plugins(paths, true);
    add_components(*impl->own_registry);
    registry = impl->own_registry.get();
  } else {
    impl = std::make_unique<Impl>();
    registry = &shared_registry(paths);
  }
  const ConfigNode root = ConfigNode::parse(*text, store_path + ConfigNode::kStoredSuffix);
  impl->init(study_detail::parse_stored_study(root, *registry, store_path), *registry);
  log_cpu("configuration parsed and validated, its plugins loaded, task built");
  const auto identity = store->meta(store_key::kIdentity);
  if (identity && !(shared && identity_checked(*registry, *text, *identity))) {
    const std::string now = study_identity(impl->config);
    if (!study_detail::same_identity(*identity, now))
      log_warn("{}: the stored configuration resolves differently with the plugins loaded now (an option added or "
               "a default changed since the study was created; first difference: {}); continuing",
               store_path, first_difference(*identity, now));
    else if (shared)
      remember_identity(*registry, *text, *identity);
  }
  impl->store = std::move(store);
  impl->address = store_path;
  impl->check_domain_unchanged();
  log_cpu("configuration checked against the stored identity");
  return Study(std::move(impl));
}

Study Study::attach(const std::string& store_path, const StudyConfig& config, const Registry& registry) {
  auto impl = std::make_unique<Study::Impl>();
  impl->init(config, registry);
  const std::string identity = study_identity(impl->config);
  if (!store_exists(store_path)) {
    create_study_store(*impl, store_path);
    return Study(std::move(impl));
  }
  impl->store = open_store(store_path);
  impl->address = store_path;
  impl->check_domain_unchanged();
  const std::string stored = impl->store->meta(store_key::kIdentity).value_or("");
  if (!study_detail::same_identity(stored, identity))
    throw InputError(fmt::format(
        "{}: this study was created from a different configuration (task, algorithm, seed and initial point must "
        "match to continue it); first difference: {}. Use another study file, or continue it with the configuration "
        "it was created with ({}, without options that change it such as a seed)",
        store_path, first_difference(stored, identity),
        // A Python objective cannot be run by the command line (red team, session 23).
        impl->config.task.info && impl->config.task.info->name == "python"
            ? std::string("`varbo.minimize(..., output=..., resume=True)` with the seed and budget it had or none")
            : fmt::format("`varbo run --resume {}`", store_path)));
  // The budget is not part of the identity (`--resume --budget 40` continues the study), but the stored
  // configuration must say the budget now in force: `varbo status` and a later `varbo suggest` read it (they showed
  // "budget 30, 0 left" after a run resumed to 33).
  const Index finished = static_cast<Index>(impl->store->next_finish_seq());
  if (impl->config.budget < finished)
    // Refused by `--resume --budget` only: `--study FILE --budget 2` (or a config's budget) on 4 finished trials
    // ran, and `varbo status` showed "4 complete (budget 2)" (red team, session 28).
    throw InputError(fmt::format("{}: budget {} is below the {} trials the study has finished; give at least {}",
                                 store_path, impl->config.budget, finished, finished));
  // So are the other operational keys: a run given `stop_after_failures: 2` stopped after two failures, and the
  // `--resume` its message advised ran with the stored 10 (red team, session 28). What runs now is recorded.
  if (const auto text = impl->store->meta(store_key::kConfig)) {
    YAML::Node n = YAML::Load(*text);
    bool changed = false;
    auto record = [&](const char* key, const YAML::Node& now) {
      if (!n.IsMap() || !n[key] || !n[key].IsScalar() || n[key].Scalar() == now.Scalar()) return;
      log_info("{}: {} {} (was {}), recorded in the study", store_path, key, now.Scalar(), n[key].Scalar());
      n[key] = now;
      changed = true;
    };
    record("budget", YAML::Node(yaml_scalar(impl->config.budget)));
    record("stop_after_failures", YAML::Node(yaml_scalar(impl->config.stop_after_failures)));
    record("heartbeat_timeout", YAML::Node(exact(impl->config.heartbeat_timeout)));
    record("retry_abandoned", YAML::Node(impl->config.retry_abandoned ? "true" : "false"));
    if (changed)
      impl->store->transaction(
          [&] { impl->store->set_meta(store_key::kConfig, "# varbo study configuration (resolved)\n" + emit(n)); });
  }
  return Study(std::move(impl));
}

void Study::validate(const StudyConfig& config, const Registry& registry) {
  Study::Impl impl;
  impl.init(config, registry);
  impl.make_algorithm();
}

std::vector<TrialRecord> Study::ask(Index q) {
  if (q < 1) throw InputError(fmt::format("ask: the batch size must be at least 1, got {}", q));
  Impl& m = live();
  m.check_file();
  // The study's `threads:` (a robot's control loop keeps its cores): only `varbo run` honoured it; an embedded
  // Study, `varbo suggest` and `varbo worker` fitted on every core (red team, session 30).
  const ThreadLimit limit(static_cast<int>(m.config.threads));
  std::vector<TrialRecord> out;
  const double asked_at = unix_time();  // before any wait for the store's lock (abandon_silent_workers)
  m.store->transaction([&] {
    out.clear();
    m.abandon_silent_workers(asked_at);
    // The budget first: a spent budget costs no model work.
    std::vector<Vec> pending;
    for (const auto& t : m.checked(m.store->pending_trials())) pending.push_back(t.x);
    const Index remaining =
        m.config.budget - static_cast<Index>(m.store->next_finish_seq()) - static_cast<Index>(pending.size());
    if (remaining <= 0) {
      // Pending trials holding the budget (an embedded node that crashed after asking, without heartbeats): the
      // empty answer read as "budget spent" and a restarted node finished after one real result (red team,
      // session 30). `varbo suggest` says it; so does ask.
      if (!pending.empty() && !std::exchange(m.said_pending_hold_budget, true))
        log_info("{}: nothing to ask: the budget of {} is held by {} finished and {} pending trial(s); a pending "
                 "trial of a process that died is freed by abandon (`varbo abandon`)",
                 m.store->location(), m.config.budget, m.store->next_finish_seq(), pending.size());
      return;
    }
    const Index room = std::min(q, remaining);
    out = m.retries(room);
    if (static_cast<Index>(out.size()) == room) {
      m.dirty = true;  // the retried points are pending now: the next ask rebuilds
      return;
    }
    // Fewer retries than asked: the rest are new points, which see the retried ones as pending (a batch of 4 with
    // one abandoned trial returned that trial alone, "the budget has no more room"; red team, session 30).
    for (const auto& t : out) pending.push_back(t.x);
    try {
      detail::in_plugin_code(*m.registry, "bringing the algorithm up to date with the study's results",
                             [&] { m.sync(); });
      log_cpu("algorithm brought up to date (saved state restored, results since told)");
      m.save_state();  // the state after every finished result, for the next process that opens the study
    } catch (...) {
      m.dirty = true;
      throw;
    }
    const auto n_finished = static_cast<std::int64_t>(m.told_ids.size());
    const Index n = room - static_cast<Index>(out.size());
    m.dirty = true;  // until the suggestion is stored
    m.alg->set_pending(pending);
    const std::string algorithm = m.config.algorithm.info->full_name();
    std::vector<Suggestion> sugg = detail::in_plugin_code(
        *m.registry, fmt::format("asking algorithm '{}' for {} point(s)", algorithm, n), [&] { return m.alg->ask(n); });
    log_cpu("algorithm asked (model fit, acquisition)");
    const Index d = m.encoded_dim();
    // What the algorithm returned is checked before anything is stored: more points than asked left stray
    // pending trials and ended a run early; a NaN coordinate reached the task and then failed in the store as
    // a "corrupt vector", blaming the store.
    if (static_cast<Index>(sugg.size()) > n)
      throw PluginCodeError(fmt::format("algorithm '{}' ({}) returned {} points when asked for {}; nothing stored",
                                        algorithm, m.config.algorithm.info->library, sugg.size(), n));
    for (const Suggestion& sg : sugg)
      if (sg.x.size() == d && !sg.x.allFinite())
        throw PluginCodeError(fmt::format("algorithm '{}' ({}) suggested a point with a non-finite coordinate; "
                                          "nothing stored",
                                          algorithm, m.config.algorithm.info->library));
    const double now = unix_time();
    for (std::size_t j = 0; j < sugg.size(); ++j) {
      TrialRecord r;
      r.state = TrialState::Pending;
      r.phase = sugg[j].phase;
      if (sugg[j].x.size() != d)
        throw InputError(fmt::format("algorithm '{}' suggested a point of dimension {}, expected {}",
                                     m.config.algorithm.info->name, sugg[j].x.size(), d));
      if (!Box::unit(d).contains(sugg[j].x, 1e-9)) log_warn("algorithm suggested a point outside the unit cube; clamping it");
      r.x = m.trial_x(sugg[j].x);
      r.theta = m.theta_of(r.x);
      std::string why;
      if (m.space && !m.space->contains(r.theta, &why))
        log_warn("algorithm '{}' suggested a point that could not be made admissible: {}", m.config.algorithm.info->name,
                 why);
      r.worker = m.worker;
      r.created_at = now;
      r.finished_before = n_finished;
      r.pending_before = static_cast<std::int64_t>(pending.size());
      r.batch_size = static_cast<std::int64_t>(sugg.size());
      r.batch_index = static_cast<std::int64_t>(j);
      r.fit_seconds = sugg[j].fit_seconds;
      r.acquisition_seconds = sugg[j].acquisition_seconds;
      r.id = m.store->add_trial(r);
      out.push_back(r);
    }
    // A serial ask: the state right after it lets the next process tell this trial's result without a fit.
    if (out.size() == 1 && pending.empty()) m.save_state(out[0].id);
    log_cpu("trial and state written");
  });
  log_cpu("committed");
  // Committed: the live algorithm stays usable only after a plain ask(1) with nothing pending.
  const bool serial = out.size() == 1 && out[0].pending_before == 0 && out[0].batch_size == 1;
  if (serial) {
    m.outstanding = out[0].id;
    m.dirty = false;
  } else if (!out.empty()) {
    m.dirty = true;
  } else if (m.alg && !m.dirty) {
    m.alg->set_pending({});  // nothing asked: the algorithm is unchanged apart from set_pending
  }
  return out;
}

namespace {
/// A component named like a fixed column (or a parameter) made a second column of that name, which csv readers
/// take for the first (`--component cost=99` was read as the cost).
bool names_a_column(const std::string& name, const std::vector<std::string>& parameters) {
  return is_trials_table_column(name) || std::find(parameters.begin(), parameters.end(), name) != parameters.end();
}

void check_result(const std::string& where, double cost, const Components& components,
                  const std::vector<std::string>& parameters) {
  for (const auto& [name, v] : components)
    if (names_a_column(name, parameters))
      throw InputError(fmt::format("{}: a cost component may not be named '{}', which names a parameter or a column of "
                                   "the trials table (index, id, state, phase, cost, ok, error, worker, the timings); "
                                   "nothing written",
                                   where, name));
  if (!std::isfinite(cost))
    throw InputError(fmt::format("{}: the cost must be a finite number, got {}; nothing written (report a trial that "
                                 "could not be measured with `varbo fail` / Study::fail)",
                                 where, cost));
  for (const auto& [name, v] : components) {
    if (name.empty()) throw InputError(fmt::format("{}: a cost component needs a name; nothing written", where));
    if (!std::isfinite(v))
      throw InputError(
          fmt::format("{}: component '{}' must be a finite number, got {}; nothing written", where, name, v));
  }
}
}  // namespace

void Study::tell(std::int64_t id, double cost, const Components& components) {
  check_result(fmt::format("{}: trial {}", live().store->location(), id), cost, components, live().domain.names);
  Evaluation e;
  e.cost = cost;
  e.components = components;
  record(id, e, 0.0);
}


namespace {
/// θ (user units) of a trial no suggestion produced, checked against the study's domain: its unit-cube point.
Vec manual_point(const Domain& domain, const SearchSpace* space, const Vec& theta, const std::string& where) {
  const Box& box = domain.box;
  std::string why;
  if (space && !space->contains(theta, &why))
    throw InputError(fmt::format("{}: θ is not admissible: {}; nothing written", where, why));
  if (theta.size() != box.dim())
    throw InputError(fmt::format("{}: θ has {} values, the study has {} parameters ({}); nothing written", where,
                                 theta.size(), box.dim(), join(domain.names)));
  for (Index i = 0; i < theta.size(); ++i)
    if (!std::isfinite(theta[i]) || theta[i] < box.lower[i] || theta[i] > box.upper[i])
      throw InputError(fmt::format("{}: θ lies outside the domain: {} = {} is not in [{}, {}]; nothing written", where,
                                   domain.names[static_cast<std::size_t>(i)], theta[i], box.lower[i], box.upper[i]));
  return space ? space->encode(theta) : Vec(Box::unit(box.dim()).clamp(to_unit(theta, box)));
}
}  // namespace

std::int64_t Study::add_manual_trial(const Vec& theta, const Evaluation& ev) {
  Impl& m = live();
  m.check_file();
  const std::string where = m.store->location();
  if (ev.ok) check_result(where + ": new trial", ev.cost, ev.components, m.domain.names);
  const Vec x = manual_point(m.domain, m.space.get(), theta, where);
  std::int64_t id = -1;
  if (ev.ok) m.check_cost_scale(-1, ev.cost);
  m.store->transaction([&] {
    TrialRecord r;
    r.state = ev.ok ? TrialState::Complete : TrialState::Failed;
    r.phase = "manual";
    r.theta = theta;
    r.x = x;
    r.cost = ev.ok ? ev.cost : std::nan("");
    r.components = ev.components;
    r.error = ev.error;
    r.worker = m.worker;
    r.created_at = r.finished_at = unix_time();
    r.batch_size = 0;  // not suggested: a replay need not reproduce it
    r.finish_seq = m.store->next_finish_seq();
    id = m.store->add_trial(r);
  });
  return id;
}

std::int64_t Study::tell_point(const Vec& theta, double cost, const Components& components) {
  Evaluation e;
  e.cost = cost;
  e.components = components;
  return add_manual_trial(theta, e);
}

namespace {
/// As a task's failure is kept (study_detail::stored_reason): `Study.fail(t, 'a\0b')` stored 'a', and a 10 MB
/// reason was kept whole (red team, session 46).
std::string kept_reason(const std::string& reason) {
  // The prefix marks a failure taken back (varbo retract): a reason beginning with it would be read as one.
  if (reason.rfind(kRetractedPrefix, 0) == 0)
    throw InputError(fmt::format("a failure's reason may not begin with \"{}\": that marks a failure taken back; "
                                 "nothing written",
                                 kRetractedPrefix));
  return reason.empty() ? std::string("failed") : study_detail::stored_reason(reason);
}
}  // namespace

std::int64_t Study::fail_point(const Vec& theta, const std::string& reason) {
  Evaluation e;
  e.ok = false;
  e.cost = std::nan("");
  e.error = kept_reason(reason);
  return add_manual_trial(theta, e);
}

TrialRecord Study::record(std::int64_t id, const Evaluation& ev, double evaluation_seconds) {
  Impl& m = live();
  m.check_file();
  std::int64_t seq = -1;
  TrialRecord t;
  m.store->transaction([&] {
    t = m.pending_trial(id, ev.ok ? "observe" : "fail");
    const bool late = t.state == TrialState::Abandoned;
    const std::string abandoned_because = t.error;
    t.state = ev.ok ? TrialState::Complete : TrialState::Failed;
    t.cost = ev.ok ? ev.cost : std::nan("");  // a failed trial has no cost (as Study::fail records it), not 0
    m.check_cost_scale(id, ev.ok ? ev.cost : 0.0);
    // A component named like a parameter or a column of the trials table (a command's answer {"cost": 2,
    // "components": {"cost": 3}}) made a second column of that name in the exports, which csv readers took for
    // the first (the trial's cost read as 3). Tell refuses it; a task's result keeps its cost and loses only that
    // component, said each time (red team, session 22).
    t.components.clear();
    for (const auto& [name, v] : ev.components) {
      if (names_a_column(name, m.domain.names)) {
        log_warn("{}: trial {}: component '{}' not recorded: it names a parameter or a column of the trials table "
                 "(index, id, state, phase, cost, ok, error, worker, the timings); rename it where the task reports it",
                 m.store->location(), id, name);
        continue;
      }
      if (!std::isfinite(v) && ev.ok && std::isfinite(ev.cost))
        // Kept as missing, and said: `varbo rescore` leaves such trials out (red team, session 26).
        log_warn("{}: trial {}: component '{}' is {} on a successful trial; recorded as missing (a re-weighting with "
                 "`varbo rescore` leaves the trial out)",
                 m.store->location(), id, name, v);
      t.components.emplace_back(name, v);
    }
    t.noiseless_cost = ev.noiseless_cost;
    t.error = ev.error;
    if (late) {
      // A late result is kept (it is a real measurement) but marked: it replaced the record of the abandonment, and
      // with retry_abandoned its θ ran again, so the study holds it twice and one more result than the budget
      // (red team, session 25). `varbo status` and the exports show this text.
      const auto retry = m.store->meta(fmt::format("retried/{}", id));
      t.error = fmt::format("late result, after: {}{}{}", abandoned_because,
                            retry ? fmt::format("; its θ was run again as trial {}", *retry) : std::string(),
                            ev.error.empty() ? std::string() : "; " + ev.error);
    }
    t.finished_at = unix_time();
    t.evaluation_seconds = evaluation_seconds;
    t.finish_seq = m.store->next_finish_seq();
    seq = t.finish_seq;
    m.store->update_trial(t);
  });
  // The serial case: tell the live algorithm now, so recommendation() and snapshot() are current.
  if (m.alg && !m.dirty && m.outstanding == id && seq == static_cast<std::int64_t>(m.told_ids.size())) {
    if (auto stored = m.store->trial(id)) {
      detail::in_plugin_code(*m.registry, fmt::format("telling algorithm '{}' the result of trial {}",
                                                      m.config.algorithm.info->full_name(), id),
                             [&] { m.alg->tell({observation_of(*stored)}); });
      m.told_ids.push_back(id);
      m.outstanding.reset();
      // After a serial ask the state saved with it already covers this result: no transaction for nothing (on
      // PostgreSQL three round trips, and the row lock's WAL flushed at commit: ~4 ms on a durable server,
      // docs/studies.md "Where a PostgreSQL open + ask spends its time").
      if (m.state_to_save()) m.store->transaction([&] { m.save_state(); });
    }
  }
  return t;
}

void Study::fail(std::int64_t id, const std::string& reason) {
  Evaluation e;
  e.ok = false;
  e.cost = std::nan("");
  e.error = kept_reason(reason);
  record(id, e, 0.0);
}

std::vector<std::int64_t> Study::abandon(double older_than_seconds, const std::string& reason) {
  if (!std::isfinite(older_than_seconds) || older_than_seconds < 0)
    throw InputError(fmt::format("{}: abandon: the age must be a finite number of seconds ≥ 0, got {}; nothing written",
                                 live().store->location(), older_than_seconds));
  const double cutoff = unix_time() - older_than_seconds;
  return abandon_where(
      [&](const TrialRecord& t) { return older_than_seconds <= 0 || t.created_at <= cutoff; }, reason);
}

std::vector<std::int64_t> Study::retract_failures(const std::vector<std::int64_t>& ids, const std::string& reason) {
  Impl& m = live();
  m.check_file();
  if (ids.empty()) throw InputError("retract: name the failed trials to take back (--id)");
  // Only bo learns where trials fail; another algorithm's replay would lose the trial's place in its own
  // bookkeeping (audit, session 48: cma_es, matching results to its population by θ, asked its old generations
  // again, trial for trial) for nothing to take back.
  if (const auto* info = m.config.algorithm.info; !info || info->name != "bo" || !is_builtin(*info))
    throw InputError(fmt::format("{}: retract: algorithm '{}' keeps no model of where trials fail, so there is "
                                 "nothing to take back (only bo's failure model learns failures); nothing written",
                                 m.store->location(), info ? info->full_name() : std::string("?")));
  // A live `varbo run` would tell its algorithm (which knows the failures) its in-flight result and save that state
  // after the retraction, where the rebuild would take it: refused here too, not only by the CLI (audit, session 48:
  // Python's retract_failures went through beside a live run).
  // On PostgreSQL too (the run lock is a server session there; red team, session 49: the CLI refused, Python did
  // not), and beside a live worker, whose algorithm was told the failures as well.
  if (m.run_is_live())
    throw InputError(fmt::format("{}: a `varbo run` is using this study; stop it first (Ctrl-C), then take the trials "
                                 "back and resume; nothing written",
                                 m.store->location()));
  const double window = m.config.heartbeat_timeout > 0 ? m.config.heartbeat_timeout : 60.0, now = unix_time();
  for (const auto& w : m.store->workers())
    if (w.state == "running" && w.id != m.worker && now - w.heartbeat_at < window && !worker_process_gone(w.id))
      throw InputError(fmt::format("{}: worker {} is working on this study (heartbeat {:.0f} s ago); stop it first, "
                                   "then take the trials back; nothing written",
                                   m.store->location(), printable(w.id), now - w.heartbeat_at));
  const std::string why = reason.empty() ? std::string("the rig, not θ, failed") : reason;
  std::vector<std::int64_t> done;
  m.store->transaction([&] {
    done.clear();
    std::vector<TrialRecord> rows;
    for (const auto id : ids) {
      const auto t = m.store->trial(id);
      if (!t) throw InputError(fmt::format("{}: no trial {}; nothing written", m.store->location(), id));
      if (retracted(*t))
        throw InputError(fmt::format("{}: trial {} was taken back already; nothing written", m.store->location(), id));
      if (t->state != TrialState::Failed)
        throw InputError(fmt::format("{}: trial {} is {}, not failed: only a failed trial is taken back; nothing "
                                     "written",
                                     m.store->location(), id, state_name(t->state)));
      if (std::find(done.begin(), done.end(), id) != done.end())
        throw InputError(fmt::format("retract: trial {} is named twice; nothing written", id));
      done.push_back(id);
      rows.push_back(*t);
    }
    for (TrialRecord& t : rows) {
      t.error = fmt::format("{} ({}); the failure was: {}", kRetractedPrefix, safe_text(why, 200), t.error);
      m.store->update_trial(t);
    }
    m.store->set_meta(kRetractedAtKey, exact(unix_time()));
  });
  m.dirty = true;  // rebuilt without them at its next use
  return done;
}

std::vector<std::int64_t> Study::abandon_where(const std::function<bool(const TrialRecord&)>& which,
                                               const std::string& reason) {
  Impl& m = live();
  m.check_file();
  std::vector<std::int64_t> ids;
  m.store->transaction([&] {
    ids.clear();
    for (TrialRecord t : m.store->pending_trials()) {
      if (!which(t)) continue;
      t.state = TrialState::Abandoned;
      t.error = reason;
      t.finished_at = unix_time();
      m.store->update_trial(t);
      ids.push_back(t.id);
    }
  });
  if (!ids.empty()) m.dirty = true;
  return ids;
}

std::optional<TrialRecord> Study::best() const {
  std::optional<TrialRecord> b;
  for (const auto& t : live().checked(live().store->trials()))
    if (t.state == TrialState::Complete && (!b || t.cost < b->cost)) b = t;
  return b;
}

std::optional<Vec> Study::recommendation() {
  Impl& m = live();
  const ThreadLimit limit(static_cast<int>(m.config.threads));
  if (m.store->next_finish_seq() == 0) return std::nullopt;
  m.store->transaction([&] {
    try {
      detail::in_plugin_code(*m.registry, "bringing the algorithm up to date with the study's results",
                             [&] { m.sync(); });
    } catch (...) {
      m.dirty = true;
      throw;
    }
  });
  const std::optional<Vec> r =
      m.alg ? detail::in_plugin_code(*m.registry,
                                     fmt::format("asking algorithm '{}' for its recommendation",
                                                 m.config.algorithm.info->full_name()),
                                     [&] { return m.alg->recommendation(); })
            : std::nullopt;
  if (!r) return std::nullopt;
  if (!study_detail::usable_recommendation(*r, m.encoded_dim(), m.config.algorithm.info->full_name(), true))
    return std::nullopt;
  return study_detail::recommended_theta(*r, m.store->trials(), m.space.get(), m.domain.box);
}

std::optional<Selection> Study::select(double kappa) const { return select(std::vector<double>{kappa}).front(); }

std::vector<std::optional<Selection>> Study::select(const std::vector<double>& kappas) const {
  // A NaN κ ordered nothing and reached an allocation sized by it (std::bad_alloc in the Python binding, py11).
  for (const double kappa : kappas)
    if (!std::isfinite(kappa)) throw InputError(fmt::format("select: kappa must be a finite number, got {}", kappa));
  std::vector<std::optional<Selection>> out(kappas.size());
  const Impl& m = live();
  const ThreadLimit limit(static_cast<int>(m.config.threads));
  std::vector<TrialRecord> done;
  for (const auto& t : m.checked(m.store->trials()))
    if (t.state == TrialState::Complete) done.push_back(t);
  if (done.empty() || kappas.empty()) return out;
  const Index d = m.encoded_dim();
  Dataset data = Dataset::empty(d);
  for (const auto& t : done) data.add(t.x, t.cost);
  ResolvedComponent spec;
  for (const auto& o : m.config.algorithm.info->options)
    if (o.name == "surrogate" && o.type == OptionType::Component) spec = m.config.algorithm.options.component("surrogate");
  if (!spec.info) spec = m.registry->resolve(Kind::Surrogate, ConfigNode::parse("gp", "<select: default surrogate>"));
  BuildContext ctx;
  ctx.dim = d;
  ctx.seed = m.config.seed;
  std::unique_ptr<Surrogate> model = respect_types(m.registry->create<Surrogate>(spec, ctx), m.space);
  Rng rng = Rng(m.config.seed).stream(0x5e1ec7);
  if (data.size() >= 2) model->fit(data, rng);
  if (data.size() < 2 || !model->ready()) {
    const auto b = best();
    Selection s;
    s.trial_id = b->id;
    s.theta = b->theta;
    s.mean = s.value = b->cost;
    log_warn("select: no usable surrogate ({} complete trials); returning the best observed trial", data.size());
    for (auto& o : out) o = s;
    return out;
  }
  for (std::size_t k = 0; k < kappas.size(); ++k) {
    const Incumbent inc = find_incumbent(*model, data, kappas[k]);
    const TrialRecord& t = done[static_cast<std::size_t>(inc.index)];
    Selection s;
    s.trial_id = t.id;
    s.theta = t.theta;
    s.mean = inc.mean;
    s.std = inc.std;
    s.value = inc.mean + kappas[k] * inc.std;
    out[k] = s;
  }
  return out;
}

std::vector<TrialRecord> Study::trials() const { return live().checked(live().store->trials()); }
const StudyConfig& Study::config() const { return live().config; }
const Domain& Study::domain() const { return live().domain; }
const SharedSpace& Study::space() const { return live().space; }
Params Study::params(const Vec& theta) const {
  const Domain& d = live().domain;
  if (theta.size() != live().theta_dim())  // a θ of another size was padded with defaults in silence
    throw InputError(fmt::format("params: θ has {} values, expected {} (one per parameter)", theta.size(),
                                 live().theta_dim()));
  return live().space ? live().space->params(theta) : SearchSpace::from_box(d.box, d.names).params(theta);
}
StudyStore& Study::store() { return *live().store; }
void Study::transaction(const std::function<void()>& body) {
  Impl& m = live();
  try {
    m.store->transaction(body);
  } catch (...) {
    // Rolled back: results the body told are gone from the store, but the live algorithm was told them; the next
    // call rebuilds it from the store (it kept a phantom result: recommendations and saved states diverged).
    m.dirty = true;
    throw;
  }
}
std::optional<std::string> Study::meta(const std::string& key) const { return live().store->meta(key); }
void Study::set_meta(const std::string& key, const std::string& value) {
  if (key.empty()) throw InputError("set_meta: an empty key; nothing written");
  live().check_file();  // else written into a deleted or replaced file, and lost (red team, session 30)
  live().store->transaction([&] { live().store->set_meta(key, value); });
}
void Study::add_model_snapshot(const StoredSnapshot& snapshot) {
  live().store->transaction([&] { live().store->add_snapshot(snapshot); });
}
std::vector<StoredSnapshot> Study::model_snapshots() const { return live().store->snapshots(); }
const Algorithm* Study::algorithm() const { return live().alg.get(); }
Task& Study::task() { return *live().task; }
void Study::set_worker(const std::string& name) { live().worker = name; }
const Registry& Study::registry() const { return *live().registry; }

void Study::heartbeat(const std::string& state) {
  // Only these two mean something to the liveness check (study_impl.cpp): another word ("banana", "Running")
  // was stored, and the worker was then never abandoned however long it stayed silent.
  if (state != "running" && state != "stopped")
    throw InputError(fmt::format("heartbeat: state '{}': expected running or stopped; nothing written",
                                 safe_text(state, 100)));
  Impl& m = live();
  m.check_file();  // a heartbeat into a deleted or replaced file kept a dead worker looking alive to nobody
  WorkerRecord w;
  w.id = m.worker;
  const auto [host, pid] = worker_host_pid(m.worker);
  w.host = host;
  w.pid = pid;
  w.started_at = w.heartbeat_at = unix_time();
  w.state = state;
  m.store->transaction([&] { m.store->put_worker(w); });
}
Index Study::replay_mismatches() const { return live().mismatches; }
Index Study::replayed() const { return live().replayed; }

}  // namespace varbo
