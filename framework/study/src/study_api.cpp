// varbo::Study: ask/tell on a study store, with the algorithm rebuilt by replaying the stored trials.
#include "varbo/study_api.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "varbo/errors.hpp"
#include "varbo/loader.hpp"
#include "varbo/log.hpp"
#include "varbo/math.hpp"

namespace fs = std::filesystem;

namespace varbo {

namespace {

constexpr double kReplayTolerance = 1e-12;  // unit-cube coordinates: a replay must give the same point

std::string emit(const YAML::Node& n) {
  YAML::Emitter em;
  em << n;
  return em.c_str();
}

std::vector<std::string> lines_of(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string l;
  while (std::getline(ss, l)) out.push_back(l);
  return out;
}

Observation observation_of(const TrialRecord& t) {
  Observation o;
  o.x = t.x;
  o.ok = t.state == TrialState::Complete;
  o.cost = o.ok ? t.cost : std::nan("");
  o.components = t.components;
  return o;
}

}  // namespace

std::string study_identity(const StudyConfig& c) {
  YAML::Node n(YAML::NodeType::Map);
  n["task"] = c.task.resolved();
  n["algorithm"] = c.algorithm.resolved();
  n["seed"] = c.seed;
  if (c.initial_point) n["initial_point"] = std::vector<double>(c.initial_point->data(), c.initial_point->data() + c.initial_point->size());
  return emit(n);
}

struct Study::Impl {
  std::unique_ptr<Registry> own_registry;
  std::unique_ptr<PluginLoader> loader;
  const Registry* registry = nullptr;
  StudyConfig config;
  std::unique_ptr<Task> task;
  Domain domain;
  std::optional<Vec> initial_unit;
  std::unique_ptr<StudyStore> store;
  std::string worker = default_worker_name();

  // The live algorithm: it has been asked once and told once for each id in told_ids (in that order), plus
  // possibly one more ask(1) whose trial is `outstanding`. Anything else (a batch, pending points) makes it
  // `dirty`: the next use rebuilds it from the store.
  std::unique_ptr<Algorithm> alg;
  std::vector<std::int64_t> told_ids;
  std::optional<std::int64_t> outstanding;
  bool dirty = true;
  Index mismatches = 0;

  /// Builds the task (for its domain) and checks the initial point, as `varbo run` does.
  void init(const StudyConfig& c, const Registry& reg) {
    registry = &reg;
    config = c;
    BuildContext tctx;
    tctx.seed = config.seed;
    task = reg.create<Task>(config.task, tctx);
    domain = task->domain();
    const Index d = domain.box.dim();
    if (d < 1)
      throw ConfigError(fmt::format("{}: task '{}' has no parameters", config.task.source.where(), config.task.info->name));
    if (!(domain.box.upper.array() > domain.box.lower.array()).all())
      throw ConfigError(fmt::format("{}: task '{}' has an empty domain (every upper bound must exceed its lower bound)",
                                    config.task.source.where(), config.task.info->name));
    for (Index i = static_cast<Index>(domain.names.size()); i < d; ++i) domain.names.push_back(fmt::format("x{}", i + 1));
    domain.names.resize(static_cast<std::size_t>(d));
    std::optional<Vec> theta0 = config.initial_point ? config.initial_point : task->initial_point();
    if (theta0) {
      if (theta0->size() != d)
        config.source.child("initial_point")
            .fail(fmt::format("expected {} values (the task's dimension), got {}", d, theta0->size()));
      if (!domain.box.contains(*theta0))
        config.source.child("initial_point").fail("the initial point lies outside the task's domain");
      initial_unit = to_unit(*theta0, domain.box);
    }
  }

  std::unique_ptr<Algorithm> make_algorithm() const {
    BuildContext actx;
    actx.dim = domain.box.dim();
    actx.seed = config.seed;
    actx.budget = config.budget;
    actx.initial_point = initial_unit;
    return registry->create<Algorithm>(config.algorithm, actx);
  }

  void rebuild() {
    alg = make_algorithm();
    told_ids.clear();
    outstanding.reset();
    dirty = false;
  }

  /// ask(1) then tell(t): the step of an uninterrupted serial run that produced t.
  void replay_one(const TrialRecord& t) {
    std::vector<Suggestion> s = alg->ask(1);
    const bool serial = t.batch_size == 1 && t.pending_before == 0 &&
                        t.finished_before == static_cast<std::int64_t>(told_ids.size());
    if (serial) {
      const bool same = s.size() == 1 && s[0].x.size() == t.x.size() &&
                        (Box::unit(t.x.size()).clamp(s[0].x) - t.x).cwiseAbs().maxCoeff() <= kReplayTolerance;
      if (!same) {
        ++mismatches;
        log_warn("{}: replaying trial {}: the algorithm now suggests a different point than it did (is the run "
                 "deterministic? same plugins?); continuing with the stored result",
                 store->location(), t.id);
      }
    }
    alg->tell({observation_of(t)});
    told_ids.push_back(t.id);
  }


  /// Brings the live algorithm in step with the finished trials of the store. finish_seq values are assigned
  /// once, in order, and never change, so only the trials finished since the last sync need reading.
  void sync() {
    if (!alg || dirty) rebuild();
    std::vector<TrialRecord> fresh = store->finished_since(static_cast<std::int64_t>(told_ids.size()));
    std::size_t i = 0;
    if (outstanding) {
      if (!fresh.empty() && fresh[0].id == *outstanding) {
        alg->tell({observation_of(fresh[0])});
        told_ids.push_back(fresh[0].id);
        outstanding.reset();
        i = 1;
      } else {
        rebuild();
        fresh = store->finished_since(0);
      }
    }
    for (; i < fresh.size(); ++i) replay_one(fresh[i]);
  }

  TrialRecord pending_trial(const std::int64_t id, const char* verb) const {
    auto t = store->trial(id);
    if (!t)
      throw InputError(fmt::format("{}: no trial with id {} (see `varbo status {}`); nothing written", store->location(),
                                   id, store->location()));
    if (t->state == TrialState::Abandoned) {
      log_warn("{}: trial {} had been abandoned; recording its late result", store->location(), id);
    } else if (t->state != TrialState::Pending) {
      throw InputError(fmt::format("{}: cannot {} trial {}: it is already {} (each trial takes one result); nothing "
                                   "written",
                                   store->location(), verb, id, state_name(t->state)));
    }
    return *t;
  }

  std::vector<std::pair<std::string, std::string>> meta_entries(const std::string& identity) const {
    std::string paths;
    for (const auto& p : plugin_paths_of(config.source)) paths += fs::absolute(p).string() + "\n";
    return {{store_key::kConfig, "# varbo study configuration (resolved)\n" + emit(config.resolved())},
            {store_key::kIdentity, identity},
            {store_key::kPluginPaths, paths}};
  }
};

Study::Study(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Study::Study(Study&&) noexcept = default;
Study& Study::operator=(Study&&) noexcept = default;
Study::~Study() = default;

namespace {
std::unique_ptr<Study::Impl> impl_with_plugins(const std::vector<std::string>& paths) {
  auto impl = std::make_unique<Study::Impl>();
  impl->own_registry = std::make_unique<Registry>();
  impl->loader = std::make_unique<PluginLoader>(*impl->own_registry);
  impl->loader->load_default(paths);
  return impl;
}

void create_store(Study::Impl& impl, const std::string& store_path) {
  impl.make_algorithm();  // surface configuration errors before any file is written
  impl.store = create_sqlite_store(store_path, impl.meta_entries(study_identity(impl.config)));
}
}  // namespace

Study Study::create(const std::string& store_path, const std::string& config_file) {
  const ConfigNode root = ConfigNode::load_file(config_file);
  auto impl = impl_with_plugins(plugin_paths_of(root));
  impl->init(parse_study(root, *impl->own_registry), *impl->own_registry);
  create_store(*impl, store_path);
  return Study(std::move(impl));
}

Study Study::create_from_yaml(const std::string& store_path, const std::string& yaml, const std::string& name) {
  const ConfigNode root = ConfigNode::parse(yaml, name);
  auto impl = impl_with_plugins(plugin_paths_of(root));
  impl->init(parse_study(root, *impl->own_registry), *impl->own_registry);
  create_store(*impl, store_path);
  return Study(std::move(impl));
}

Study Study::open(const std::string& store_path) {
  std::unique_ptr<StudyStore> store = open_sqlite_store(store_path);
  const auto text = store->meta(store_key::kConfig);
  if (!text) throw InputError(fmt::format("{}: the study store holds no configuration (corrupt store?)", store_path));
  std::vector<std::string> paths;
  for (const auto& l : lines_of(store->meta(store_key::kPluginPaths).value_or("")))
    if (!l.empty()) paths.push_back(l);
  auto impl = impl_with_plugins(paths);
  const ConfigNode root = ConfigNode::parse(*text, store_path + " (stored configuration)");
  impl->init(parse_study(root, *impl->own_registry), *impl->own_registry);
  const auto identity = store->meta(store_key::kIdentity);
  if (identity && *identity != study_identity(impl->config))
    log_warn("{}: the stored configuration resolves differently with the plugins loaded now (plugin defaults "
             "changed?); continuing",
             store_path);
  impl->store = std::move(store);
  return Study(std::move(impl));
}

Study Study::attach(const std::string& store_path, const StudyConfig& config, const Registry& registry) {
  auto impl = std::make_unique<Study::Impl>();
  impl->init(config, registry);
  const std::string identity = study_identity(impl->config);
  if (!fs::exists(store_path)) {
    create_store(*impl, store_path);
    return Study(std::move(impl));
  }
  impl->store = open_sqlite_store(store_path);
  const std::string stored = impl->store->meta(store_key::kIdentity).value_or("");
  if (stored != identity) {
    const auto a = lines_of(stored), b = lines_of(identity);
    std::size_t i = 0;
    while (i < a.size() && i < b.size() && a[i] == b[i]) ++i;
    throw InputError(fmt::format(
        "{}: this study was created from a different configuration (task, algorithm, seed and initial point must "
        "match to continue it); first difference: stored '{}' vs now '{}'. Use another study file, or "
        "`varbo run --resume {}` to continue with the stored configuration",
        store_path, i < a.size() ? a[i] : "<end>", i < b.size() ? b[i] : "<end>", store_path));
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
  Impl& m = *impl_;
  std::vector<TrialRecord> out;
  m.store->transaction([&] {
    out.clear();
    try {
      m.sync();
    } catch (...) {
      m.dirty = true;
      throw;
    }
    const auto n_finished = static_cast<std::int64_t>(m.told_ids.size());
    std::vector<Vec> pending;
    for (const auto& t : m.store->pending_trials()) pending.push_back(t.x);
    const Index remaining = m.config.budget - static_cast<Index>(n_finished) - static_cast<Index>(pending.size());
    if (remaining <= 0) return;
    const Index n = std::min(q, remaining);
    m.dirty = true;  // until the suggestion is stored
    m.alg->set_pending(pending);
    std::vector<Suggestion> sugg = m.alg->ask(n);
    const Index d = m.domain.box.dim();
    const double now = unix_time();
    for (std::size_t j = 0; j < sugg.size(); ++j) {
      TrialRecord r;
      r.state = TrialState::Pending;
      r.phase = sugg[j].phase;
      if (sugg[j].x.size() != d)
        throw InputError(fmt::format("algorithm '{}' suggested a point of dimension {}, expected {}",
                                     m.config.algorithm.info->name, sugg[j].x.size(), d));
      if (!Box::unit(d).contains(sugg[j].x, 1e-9)) log_warn("algorithm suggested a point outside the unit cube; clamping it");
      r.x = Box::unit(d).clamp(sugg[j].x);
      r.theta = from_unit(r.x, m.domain.box);
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
  });
  // Committed: the live algorithm stays usable only after a plain ask(1) with nothing pending.
  const bool serial = out.size() == 1 && out[0].pending_before == 0;
  if (serial) {
    m.outstanding = out[0].id;
    m.dirty = false;
  } else if (!out.empty()) {
    m.dirty = true;
  } else {
    m.dirty = false;  // nothing asked (budget spent): the algorithm is unchanged apart from set_pending
    if (m.alg) m.alg->set_pending({});
  }
  return out;
}

namespace {
void check_result(const std::string& where, double cost, const Components& components) {
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
  check_result(fmt::format("{}: trial {}", impl_->store->location(), id), cost, components);
  Evaluation e;
  e.cost = cost;
  e.components = components;
  record(id, e, 0.0);
}


std::int64_t Study::tell_point(const Vec& theta, double cost, const Components& components) {
  Impl& m = *impl_;
  const std::string where = m.store->location();
  check_result(where + ": new trial", cost, components);
  const Box& box = m.domain.box;
  if (theta.size() != box.dim())
    throw InputError(fmt::format("{}: θ has {} values, the study has {} parameters ({}); nothing written", where,
                                 theta.size(), box.dim(), join(m.domain.names)));
  for (Index i = 0; i < theta.size(); ++i)
    if (!std::isfinite(theta[i]) || theta[i] < box.lower[i] || theta[i] > box.upper[i])
      throw InputError(fmt::format("{}: θ lies outside the domain: {} = {} is not in [{}, {}]; nothing written", where,
                                   m.domain.names[static_cast<std::size_t>(i)], theta[i], box.lower[i], box.upper[i]));
  std::int64_t id = -1;
  m.store->transaction([&] {
    TrialRecord r;
    r.state = TrialState::Complete;
    r.phase = "manual";
    r.theta = theta;
    r.x = Box::unit(box.dim()).clamp(to_unit(theta, box));
    r.cost = cost;
    r.components = components;
    r.worker = m.worker;
    r.created_at = r.finished_at = unix_time();
    r.batch_size = 0;  // not suggested: a replay need not reproduce it
    r.finish_seq = m.store->next_finish_seq();
    id = m.store->add_trial(r);
  });
  return id;
}

void Study::record(std::int64_t id, const Evaluation& ev, double evaluation_seconds) {
  Impl& m = *impl_;
  std::int64_t seq = -1;
  m.store->transaction([&] {
    TrialRecord t = m.pending_trial(id, ev.ok ? "observe" : "fail");
    t.state = ev.ok ? TrialState::Complete : TrialState::Failed;
    t.cost = ev.cost;
    t.components = ev.components;
    t.noiseless_cost = ev.noiseless_cost;
    t.error = ev.error;
    t.finished_at = unix_time();
    t.evaluation_seconds = evaluation_seconds;
    t.finish_seq = m.store->next_finish_seq();
    seq = t.finish_seq;
    m.store->update_trial(t);
  });
  // The serial case: tell the live algorithm now, so recommendation() and snapshot() are current.
  if (m.alg && !m.dirty && m.outstanding == id && seq == static_cast<std::int64_t>(m.told_ids.size())) {
    if (auto t = m.store->trial(id)) {
      m.alg->tell({observation_of(*t)});
      m.told_ids.push_back(id);
      m.outstanding.reset();
    }
  }
}

void Study::fail(std::int64_t id, const std::string& reason) {
  Evaluation e;
  e.ok = false;
  e.cost = std::nan("");
  e.error = reason.empty() ? std::string("failed") : reason;
  record(id, e, 0.0);
}

std::vector<std::int64_t> Study::abandon(double older_than_seconds, const std::string& reason) {
  if (!std::isfinite(older_than_seconds) || older_than_seconds < 0)
    throw InputError(fmt::format("{}: abandon: the age must be a finite number of seconds ≥ 0, got {}; nothing written",
                                 impl_->store->location(), older_than_seconds));
  Impl& m = *impl_;
  std::vector<std::int64_t> ids;
  m.store->transaction([&] {
    ids.clear();
    const double cutoff = unix_time() - older_than_seconds;
    for (TrialRecord t : m.store->trials()) {
      if (t.state != TrialState::Pending || (older_than_seconds > 0 && t.created_at > cutoff)) continue;
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
  for (const auto& t : impl_->store->trials())
    if (t.state == TrialState::Complete && (!b || t.cost < b->cost)) b = t;
  return b;
}

std::optional<Selection> Study::select(double kappa) const {
  const Impl& m = *impl_;
  std::vector<TrialRecord> done;
  for (const auto& t : m.store->trials())
    if (t.state == TrialState::Complete) done.push_back(t);
  if (done.empty()) return std::nullopt;
  const Index d = m.domain.box.dim();
  Dataset data = Dataset::empty(d);
  for (const auto& t : done) data.add(t.x, t.cost);
  ResolvedComponent spec;
  for (const auto& o : m.config.algorithm.info->options)
    if (o.name == "surrogate" && o.type == OptionType::Component) spec = m.config.algorithm.options.component("surrogate");
  if (!spec.info) spec = m.registry->resolve(Kind::Surrogate, ConfigNode::parse("gp", "<select: default surrogate>"));
  BuildContext ctx;
  ctx.dim = d;
  ctx.seed = m.config.seed;
  std::unique_ptr<Surrogate> model = m.registry->create<Surrogate>(spec, ctx);
  Rng rng = Rng(m.config.seed).stream(0x5e1ec7);
  Selection s;
  if (data.size() >= 2) model->fit(data, rng);
  if (data.size() < 2 || !model->ready()) {
    const auto b = best();
    s.trial_id = b->id;
    s.theta = b->theta;
    s.mean = s.value = b->cost;
    log_warn("select: no usable surrogate ({} complete trials); returning the best observed trial", data.size());
    return s;
  }
  const Incumbent inc = find_incumbent(*model, data, kappa);
  const TrialRecord& t = done[static_cast<std::size_t>(inc.index)];
  s.trial_id = t.id;
  s.theta = t.theta;
  s.mean = inc.mean;
  s.std = inc.std;
  s.value = inc.mean + kappa * inc.std;
  return s;
}

std::vector<TrialRecord> Study::trials() const { return impl_->store->trials(); }
const StudyConfig& Study::config() const { return impl_->config; }
const Domain& Study::domain() const { return impl_->domain; }
StudyStore& Study::store() { return *impl_->store; }
const Algorithm* Study::algorithm() const { return impl_->alg.get(); }
Task& Study::task() { return *impl_->task; }
void Study::set_worker(const std::string& name) { impl_->worker = name; }
Index Study::replay_mismatches() const { return impl_->mismatches; }

}  // namespace varbo
