// varbo::Study: ask/tell on a study store. The algorithm is rebuilt from its latest saved state (when it offers
// AlgorithmState, varbo/state.hpp) plus a replay of the trials finished since; else by replaying every trial.
#include "varbo/study_api.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <tuple>

#include "varbo/csv.hpp"
#include "varbo/errors.hpp"
#include "varbo/loader.hpp"
#include "varbo/log.hpp"
#include "varbo/math.hpp"
#include "varbo/search_space_config.hpp"
#include "varbo/space_wrappers.hpp"
#include "varbo/state.hpp"

namespace fs = std::filesystem;

namespace varbo {

namespace {

constexpr double kReplayTolerance = 1e-12;  // unit-cube coordinates: a replay must give the same point

std::string emit(const YAML::Node& n) {
  YAML::Emitter em;
  em << n;
  return em.c_str();
}

std::string join_numbers(const Vec& v) {
  std::string s = "[";
  for (Index i = 0; i < v.size(); ++i) s += (i ? ", " : "") + exact(v[i]);
  return s + "]";
}

std::vector<std::string> lines_of(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string l;
  while (std::getline(ss, l)) out.push_back(l);
  return out;
}

/// The process's CPU time so far (all threads) at a step of opening a study or asking it, in the --verbose log:
/// what a short `varbo suggest` process spends where (docs/studies.md, "Cost of varbo suggest").
void log_cpu(const char* step) {
  if (log_level() <= LogLevel::Debug)
    log_debug("study: {}: process CPU {:.2f} ms", step, 1e3 * static_cast<double>(std::clock()) / CLOCKS_PER_SEC);
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
  // Only when present: the identity of a study without them is unchanged.
  if (c.parameters) n["parameters"] = YAML::Clone(c.source.child("parameters").yaml());
  if (c.constraints.defined()) n["constraints"] = YAML::Clone(c.constraints.yaml());
  return emit(n);
}

struct Study::Impl {
  std::unique_ptr<Registry> own_registry;
  std::unique_ptr<PluginLoader> loader;
  const Registry* registry = nullptr;
  StudyConfig config;
  std::unique_ptr<Task> task;
  Domain domain;
  SharedSpace space;  ///< typed parameters and constraints (docs/search_space.md); null for a plain box
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
  Index replayed = 0;         ///< trials replayed (ask + tell) since this object was opened
  /// How far the stored states reach (told results, +1 for a state with an outstanding trial): a state is
  /// saved only when the live algorithm is further.
  std::int64_t saved_reach = -1;

  /// Builds the task (for its domain) and checks the initial point, as `varbo run` does.
  void init(const StudyConfig& c, const Registry& reg) {
    registry = &reg;
    config = c;
    BuildContext tctx;
    tctx.seed = config.seed;
    task = reg.create<Task>(config.task, tctx);
    init_space();
    const Index d = domain.box.dim();
    if (d < 1)
      throw ConfigError(fmt::format("{}: task '{}' has no parameters{}", config.task.source.where(), config.task.info->name,
                                    dynamic_cast<SpaceAware*>(task.get())
                                        ? ": give its dim, lower/upper or names, or declare the study's `parameters:`"
                                        : ""));
    if (!space && !(domain.box.upper.array() > domain.box.lower.array()).all())
      throw ConfigError(fmt::format("{}: task '{}' has an empty domain (every upper bound must exceed its lower bound)",
                                    config.task.source.where(), config.task.info->name));
    for (Index i = static_cast<Index>(domain.names.size()); i < d; ++i) domain.names.push_back(fmt::format("x{}", i + 1));
    domain.names.resize(static_cast<std::size_t>(d));
    std::optional<Vec> theta0 = config.initial_point ? config.initial_point : task->initial_point();
    if (theta0) {
      if (theta0->size() != d)
        config.source.child("initial_point")
            .fail(fmt::format("expected {} values (the task's dimension), got {}", d, theta0->size()));
      std::string why;
      if (space && !space->contains(*theta0, &why))
        config.source.child("initial_point").fail("the initial point is not admissible: " + why);
      if (!domain.box.contains(*theta0))
        config.source.child("initial_point").fail("the initial point lies outside the task's domain");
      initial_unit = space ? space->encode(*theta0) : to_unit(*theta0, domain.box);
    }
  }

  void init_space() { space = resolve_study_space(config, *task, domain); }

  /// The point a trial records for the algorithm's suggestion x (unit cube): admissible in the space.
  Vec trial_x(const Vec& x) const {
    const Index d = x.size();
    return space ? space->admissible(x) : Vec(Box::unit(d).clamp(x));
  }
  Vec theta_of(const Vec& x) const { return space ? space->decode(x) : from_unit(x, domain.box); }
  Index encoded_dim() const { return space ? space->encoded_dim() : domain.box.dim(); }

  std::unique_ptr<Algorithm> make_algorithm() const {
    BuildContext actx;
    actx.dim = encoded_dim();
    actx.seed = config.seed;
    actx.budget = config.budget;
    actx.initial_point = initial_unit;
    std::unique_ptr<Algorithm> a = registry->create<Algorithm>(config.algorithm, actx);
    if (space)
      if (auto* aware = dynamic_cast<SpaceAware*>(a.get())) aware->set_search_space(space);
    return a;
  }

  static std::vector<Observation> observations_of(const std::vector<TrialRecord>& trials, std::size_t n) {
    std::vector<Observation> out;
    for (std::size_t i = 0; i < n; ++i) out.push_back(observation_of(trials[i]));
    return out;
  }

  /// The saved state reaching furthest into `finished` (the finished trials in finish order), and its reach
  /// (results it stands for: +1 for a state after an ask whose trial finished next); nullptr if none.
  const AlgorithmSnapshot* best_state(const std::vector<AlgorithmSnapshot>& states,
                                      const std::vector<TrialRecord>& finished, std::int64_t& best_reach) const {
    const AlgorithmSnapshot* best = nullptr;
    best_reach = 0;
    const auto n = static_cast<std::int64_t>(finished.size());
    for (const auto& s : states) {
      if (s.finished > n) continue;
      std::int64_t reach = s.finished;
      if (s.outstanding >= 0) {
        // Usable only when that trial was the next to finish: it is then told without a new fit.
        if (s.finished >= n || finished[static_cast<std::size_t>(s.finished)].id != s.outstanding) continue;
        ++reach;
      }
      // Newest first; at equal reach a state after a result (nothing to tell) before one after an ask.
      if (!best || reach > best_reach || (reach == best_reach && best->outstanding >= 0 && s.outstanding < 0)) {
        best = &s;
        best_reach = reach;
      }
    }
    return best;
  }

  /// A fresh algorithm, continued from the saved state that reaches furthest into the finished trials when
  /// the algorithm offers AlgorithmState; sync() replays the rest. Returns the finished trials it read (all of
  /// them, in finish order), or nothing when it read none.
  std::optional<std::vector<TrialRecord>> rebuild() {
    alg = make_algorithm();
    told_ids.clear();
    outstanding.reset();
    dirty = false;
    auto* resumable = dynamic_cast<AlgorithmState*>(alg.get());
    if (!resumable) return std::nullopt;
    std::vector<TrialRecord> finished = store->finished_since(0);
    const std::vector<AlgorithmSnapshot> states = store->algorithm_states();
    std::int64_t reach = 0;
    const AlgorithmSnapshot* best = best_state(states, finished, reach);
    saved_reach = std::max(saved_reach, reach);
    if (!best) return finished;
    const auto m = static_cast<std::size_t>(best->finished);
    try {
      resumable->restore_state(best->state, observations_of(finished, m));
    } catch (const Error& e) {
      log_warn("{}: the saved algorithm state after {} trials cannot be used ({}); replaying the study instead",
               store->location(), m, e.what());
      alg = make_algorithm();
      return finished;
    }
    for (std::size_t i = 0; i < m; ++i) told_ids.push_back(finished[i].id);
    if (best->outstanding >= 0) outstanding = best->outstanding;
    return finished;
  }

  /// The finished trials from finish_seq told_ids.size() on: taken from `all` (every finished trial, in finish
  /// order, as rebuild() just read them) when given, else read from the store.
  std::vector<TrialRecord> untold(std::optional<std::vector<TrialRecord>>&& all) const {
    const auto told = static_cast<std::int64_t>(told_ids.size());
    if (!all) return store->finished_since(told);
    // finished_since(told): those with finish_seq >= told, `all` being sorted by finish_seq.
    all->erase(all->begin(), std::partition_point(all->begin(), all->end(),
                                                  [&](const TrialRecord& t) { return t.finish_seq < told; }));
    return std::move(*all);
  }

  /// True when other processes finished more than one trial since this object's algorithm was told and a
  /// saved state covers them: restoring it is cheaper than replaying them (one fit each).
  bool saved_state_is_further() const {
    if (!dynamic_cast<const AlgorithmState*>(alg.get())) return false;
    if (store->next_finish_seq() <= static_cast<std::int64_t>(told_ids.size()) + 1) return false;
    const std::vector<TrialRecord> finished = store->finished_since(0);
    std::int64_t reach = 0;
    best_state(store->algorithm_states(), finished, reach);
    return reach > static_cast<std::int64_t>(told_ids.size()) + 1;
  }

  /// The caller makes sure the live algorithm is in a canonical state: told every finished result in finish
  /// order, nothing pending, and at most one serial ask(1) since (the trial `asked_for`).
  void save_state(std::optional<std::int64_t> asked_for = std::nullopt) {
    auto* resumable = dynamic_cast<const AlgorithmState*>(alg.get());
    if (!resumable || !alg) return;
    const auto told = static_cast<std::int64_t>(told_ids.size());
    const std::int64_t reach = told + (asked_for ? 1 : 0);
    if (reach <= saved_reach) return;
    // A state that cannot be saved costs the next process a replay, never this suggestion or result.
    try {
      const std::optional<std::string> text = resumable->save_state();
      if (!text) return;
      AlgorithmSnapshot s;
      s.finished = told;
      s.outstanding = asked_for.value_or(-1);
      s.state = *text;
      s.created_at = unix_time();
      store->add_algorithm_state(s);
      saved_reach = reach;
    } catch (const std::exception& e) {
      log_warn("{}: the algorithm state after {} result(s) was not saved ({}); the next process replays instead",
               store->location(), told, e.what());
    }
  }

  /// ask(1) then tell(t): the step of an uninterrupted serial run that produced t.
  void replay_one(const TrialRecord& t) {
    ++replayed;
    std::vector<Suggestion> s = alg->ask(1);
    const bool serial = t.batch_size == 1 && t.pending_before == 0 &&
                        t.finished_before == static_cast<std::int64_t>(told_ids.size());
    if (serial) {
      const bool same = s.size() == 1 && s[0].x.size() == t.x.size() &&
                        (trial_x(s[0].x) - t.x).cwiseAbs().maxCoeff() <= kReplayTolerance;
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
    std::optional<std::vector<TrialRecord>> read;
    if (!alg || dirty || saved_state_is_further()) read = rebuild();
    std::vector<TrialRecord> fresh = untold(std::move(read));
    std::size_t i = 0;
    if (outstanding) {
      if (!fresh.empty() && fresh[0].id == *outstanding) {
        alg->tell({observation_of(fresh[0])});
        told_ids.push_back(fresh[0].id);
        outstanding.reset();
        i = 1;
      } else {
        // The trial this object asked for did not finish next: the state after that ask is not the canonical
        // one (results told in finish order); start again from the saved states.
        fresh = untold(rebuild());
        if (outstanding) {  // a saved state that had asked for exactly the next trial to finish
          alg->tell({observation_of(fresh[0])});
          told_ids.push_back(fresh[0].id);
          outstanding.reset();
          i = 1;
        }
      }
    }
    for (; i < fresh.size(); ++i) replay_one(fresh[i]);
  }

  /// Pending trials of workers silent for longer than heartbeat_timeout are abandoned (their results will
  /// not come: the worker died, on this machine or another). Trials of processes that never sent a heartbeat
  /// (`varbo suggest`) are left alone.
  void abandon_silent_workers() {
    if (!(config.heartbeat_timeout > 0)) return;
    const double now = unix_time();
    std::vector<WorkerRecord> silent;
    for (const auto& w : store->workers())
      if (w.state == "running" && now - w.heartbeat_at > config.heartbeat_timeout) silent.push_back(w);
    if (silent.empty()) return;
    for (TrialRecord t : store->pending_trials()) {
      for (const auto& w : silent) {
        if (t.worker != w.id) continue;
        t.state = TrialState::Abandoned;
        t.error = fmt::format("abandoned: worker {} silent for {:.0f} s (heartbeat_timeout {} s)", w.id,
                              now - w.heartbeat_at, config.heartbeat_timeout);
        t.finished_at = now;
        store->update_trial(t);
        log_warn("{}: trial {} {}", store->location(), t.id, t.error);
        dirty = true;
      }
    }
  }

  /// With retry_abandoned: new pending trials at the θ of abandoned trials not retried yet (phase "retry"),
  /// at most `q`. The meta key retried/<id> links an abandoned trial to its retry.
  std::vector<TrialRecord> retries(Index q) {
    std::vector<TrialRecord> out;
    if (!config.retry_abandoned) return out;
    for (const auto& a : store->trials()) {
      if (static_cast<Index>(out.size()) >= q) break;
      if (a.state != TrialState::Abandoned || a.phase == "manual") continue;
      const std::string key = fmt::format("retried/{}", a.id);
      if (store->meta(key)) continue;
      TrialRecord r;
      r.state = TrialState::Pending;
      r.phase = "retry";
      r.x = a.x;
      r.theta = a.theta;
      r.worker = worker;
      r.created_at = unix_time();
      r.finished_before = store->next_finish_seq();
      r.batch_size = 0;  // not suggested by the algorithm: a replay need not reproduce it
      r.id = store->add_trial(r);
      store->set_meta(key, std::to_string(r.id));
      out.push_back(r);
    }
    return out;
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
/// `on_demand`: a study being opened loads only the built-in plugins its configuration looks up (loader.hpp);
/// `varbo suggest` pays for two or three libraries, not every one installed.
std::unique_ptr<Study::Impl> impl_with_plugins(const std::vector<std::string>& paths, bool on_demand = false) {
  auto impl = std::make_unique<Study::Impl>();
  impl->own_registry = std::make_unique<Registry>();
  impl->loader = std::make_unique<PluginLoader>(*impl->own_registry);
  impl->loader->set_on_demand(on_demand);
  impl->loader->load_default(paths);
  return impl;
}

/// The plugins of the studies a process opens (Study::open without components of the caller's), one registry
/// and loader per plugin path, shared by every Study opened with that path and kept for the life of the
/// process (plugins are never unloaded anyway): a second Study::open in the process neither reads the
/// plugin index nor checks, maps and registers its libraries again (docs/studies.md, "Cost of varbo
/// suggest"). Libraries still load on demand, into the shared registry (Registry guards its list for
/// that). The key holds the study's extra plugin paths and VARBO_PLUGIN_PATH with the size and time of every
/// library file they name, so that a library added or replaced there is seen as it was before (a fresh
/// registry); the built-in folders are the build's own. Warnings of the loader (a missing plugin path) are
/// given by the first open only.
struct SharedPlugins {
  Registry registry;
  PluginLoader loader{registry};
};

std::string plugin_key(const std::vector<std::string>& extra) {
  std::string key;
  auto add_file = [&key](const fs::path& p) {
    std::error_code ec;
    const auto size = fs::file_size(p, ec);
    const auto time = fs::last_write_time(p, ec);
    key += fmt::format("{}|{}|{}\n", p.string(), ec ? 0 : size, ec ? 0 : time.time_since_epoch().count());
  };
  std::vector<std::string> paths = extra;
  for (auto& p : PluginLoader::env_path()) paths.push_back(std::move(p));
  for (const auto& p : paths) {
    key += "path " + p + "\n";
    std::error_code ec;
    if (!fs::is_directory(p, ec)) {
      add_file(p);
      continue;
    }
    std::vector<fs::path> files;
    for (fs::directory_iterator it(p, ec), end; !ec && it != end; it.increment(ec)) files.push_back(it->path());
    std::sort(files.begin(), files.end());
    for (const auto& f : files)
      if (f.extension() == ".so") add_file(f);
  }
  return key;
}

const Registry& shared_registry(const std::vector<std::string>& extra) {
  static std::mutex mutex;
  static auto* cache = new std::map<std::string, std::unique_ptr<SharedPlugins>>();  // never freed (see above)
  const std::string key = plugin_key(extra);
  std::lock_guard<std::mutex> lock(mutex);
  auto it = cache->find(key);
  if (it == cache->end()) {
    auto plugins = std::make_unique<SharedPlugins>();
    plugins->loader.set_on_demand(true);
    plugins->loader.load_default(extra);  // throws (nothing cached) when a plugin named explicitly cannot load
    it = cache->emplace(key, std::move(plugins)).first;
  }
  return it->second->registry;
}

/// Stored configurations whose identity was found to match with a shared registry: the check (a YAML emit of
/// the resolved configuration) gives the same answer for the same text and the same loaded plugins, so a
/// process checks each study once.
std::mutex& identity_mutex() {
  static std::mutex m;
  return m;
}
std::set<std::tuple<const Registry*, std::string, std::string>>& identities_checked() {
  static auto* s = new std::set<std::tuple<const Registry*, std::string, std::string>>();
  return *s;
}
bool identity_checked(const Registry& registry, const std::string& text, const std::string& identity) {
  std::lock_guard<std::mutex> lock(identity_mutex());
  return identities_checked().count({&registry, text, identity}) > 0;
}
void remember_identity(const Registry& registry, const std::string& text, const std::string& identity) {
  std::lock_guard<std::mutex> lock(identity_mutex());
  identities_checked().insert({&registry, text, identity});
}

void create_study_store(Study::Impl& impl, const std::string& store_path) {
  impl.make_algorithm();  // surface configuration errors before any file is written
  impl.store = create_store(store_path, impl.meta_entries(study_identity(impl.config)));
}
}  // namespace

Study Study::create(const std::string& store_path, const std::string& config_file) {
  const ConfigNode root = ConfigNode::load_file(config_file);
  auto impl = impl_with_plugins(plugin_paths_of(root));
  impl->init(parse_study(root, *impl->own_registry), *impl->own_registry);
  create_study_store(*impl, store_path);
  return Study(std::move(impl));
}

Study Study::create_from_yaml(const std::string& store_path, const std::string& yaml, const std::string& name) {
  const ConfigNode root = ConfigNode::parse(yaml, name);
  auto impl = impl_with_plugins(plugin_paths_of(root));
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
  std::vector<std::string> paths;
  for (const auto& l : lines_of(store->meta(store_key::kPluginPaths).value_or("")))
    if (!l.empty()) paths.push_back(l);
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
  const ConfigNode root = ConfigNode::parse(*text, store_path + " (stored configuration)");
  impl->init(parse_study(root, *registry), *registry);
  log_cpu("configuration parsed and validated, its plugins loaded, task built");
  const auto identity = store->meta(store_key::kIdentity);
  if (identity && !(shared && identity_checked(*registry, *text, *identity))) {
    if (*identity != study_identity(impl->config))
      log_warn("{}: the stored configuration resolves differently with the plugins loaded now (plugin defaults "
               "changed?); continuing",
               store_path);
    else if (shared)
      remember_identity(*registry, *text, *identity);
  }
  impl->store = std::move(store);
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
    m.abandon_silent_workers();
    // The budget first: a spent budget costs no model work.
    std::vector<Vec> pending;
    for (const auto& t : m.store->pending_trials()) pending.push_back(t.x);
    const Index remaining =
        m.config.budget - static_cast<Index>(m.store->next_finish_seq()) - static_cast<Index>(pending.size());
    if (remaining <= 0) return;
    out = m.retries(std::min(q, remaining));
    if (!out.empty()) {
      m.dirty = true;  // the retried points are pending now: the next ask rebuilds
      return;
    }
    try {
      m.sync();
      log_cpu("algorithm brought up to date (saved state restored, results since told)");
      m.save_state();  // the state after every finished result, for the next process that opens the study
    } catch (...) {
      m.dirty = true;
      throw;
    }
    const auto n_finished = static_cast<std::int64_t>(m.told_ids.size());
    const Index n = std::min(q, remaining);
    m.dirty = true;  // until the suggestion is stored
    m.alg->set_pending(pending);
    std::vector<Suggestion> sugg = m.alg->ask(n);
    log_cpu("algorithm asked (model fit, acquisition)");
    const Index d = m.encoded_dim();
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
  std::string why;
  if (m.space && !m.space->contains(theta, &why))
    throw InputError(fmt::format("{}: θ is not admissible: {}; nothing written", where, why));
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
    r.x = m.space ? m.space->encode(theta) : Vec(Box::unit(box.dim()).clamp(to_unit(theta, box)));
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

TrialRecord Study::record(std::int64_t id, const Evaluation& ev, double evaluation_seconds) {
  Impl& m = *impl_;
  std::int64_t seq = -1;
  TrialRecord t;
  m.store->transaction([&] {
    t = m.pending_trial(id, ev.ok ? "observe" : "fail");
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
    if (auto stored = m.store->trial(id)) {
      m.alg->tell({observation_of(*stored)});
      m.told_ids.push_back(id);
      m.outstanding.reset();
      m.store->transaction([&] { m.save_state(); });
    }
  }
  return t;
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
  const double cutoff = unix_time() - older_than_seconds;
  return abandon_where(
      [&](const TrialRecord& t) { return older_than_seconds <= 0 || t.created_at <= cutoff; }, reason);
}

std::vector<std::int64_t> Study::abandon_where(const std::function<bool(const TrialRecord&)>& which,
                                               const std::string& reason) {
  Impl& m = *impl_;
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
  for (const auto& t : impl_->store->trials())
    if (t.state == TrialState::Complete && (!b || t.cost < b->cost)) b = t;
  return b;
}

std::optional<Selection> Study::select(double kappa) const {
  // A NaN κ ordered nothing and reached an allocation sized by it (std::bad_alloc in the Python binding, py11).
  if (!std::isfinite(kappa)) throw InputError(fmt::format("select: kappa must be a finite number, got {}", kappa));
  const Impl& m = *impl_;
  std::vector<TrialRecord> done;
  for (const auto& t : m.store->trials())
    if (t.state == TrialState::Complete) done.push_back(t);
  if (done.empty()) return std::nullopt;
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
const SharedSpace& Study::space() const { return impl_->space; }
Params Study::params(const Vec& theta) const {
  const Domain& d = impl_->domain;
  return impl_->space ? impl_->space->params(theta) : SearchSpace::from_box(d.box, d.names).params(theta);
}
StudyStore& Study::store() { return *impl_->store; }
void Study::transaction(const std::function<void()>& body) { impl_->store->transaction(body); }
std::optional<std::string> Study::meta(const std::string& key) const { return impl_->store->meta(key); }
void Study::set_meta(const std::string& key, const std::string& value) {
  impl_->store->transaction([&] { impl_->store->set_meta(key, value); });
}
void Study::add_model_snapshot(const StoredSnapshot& snapshot) {
  impl_->store->transaction([&] { impl_->store->add_snapshot(snapshot); });
}
std::vector<StoredSnapshot> Study::model_snapshots() const { return impl_->store->snapshots(); }
const Algorithm* Study::algorithm() const { return impl_->alg.get(); }
Task& Study::task() { return *impl_->task; }
void Study::set_worker(const std::string& name) { impl_->worker = name; }
const Registry& Study::registry() const { return *impl_->registry; }

void Study::heartbeat(const std::string& state) {
  Impl& m = *impl_;
  WorkerRecord w;
  w.id = m.worker;
  const auto [host, pid] = worker_host_pid(m.worker);
  w.host = host;
  w.pid = pid;
  w.started_at = w.heartbeat_at = unix_time();
  w.state = state;
  m.store->transaction([&] { m.store->put_worker(w); });
}
Index Study::replay_mismatches() const { return impl_->mismatches; }
Index Study::replayed() const { return impl_->replayed; }

namespace {
std::string first_difference(const std::string& stored, const std::string& replayed) {
  std::size_t i = 0;
  while (i < stored.size() && i < replayed.size() && stored[i] == replayed[i]) ++i;
  const std::size_t from = i > 40 ? i - 40 : 0;
  return fmt::format("at character {}: stored '…{}…' vs replayed '…{}…'", i, stored.substr(from, 100),
                     replayed.substr(from, 100));
}
}  // namespace

VerifyReport Study::verify() {
  Impl& m = *impl_;
  VerifyReport rep;
  std::unique_ptr<Algorithm> alg = m.make_algorithm();
  const auto* resumable = dynamic_cast<const AlgorithmState*>(alg.get());
  const std::vector<TrialRecord> finished = m.store->finished_since(0);
  const std::vector<AlgorithmSnapshot> states = m.store->algorithm_states();
  // A state saved by an earlier version may write the same values in another form (a list per vector before
  // vectors became one scalar): what counts is the state it restores, so it is compared as this version saves it.
  auto as_saved_now = [&](const AlgorithmSnapshot& s) -> std::optional<std::string> {
    try {
      std::unique_ptr<Algorithm> fresh = m.make_algorithm();
      auto* r = dynamic_cast<AlgorithmState*>(fresh.get());
      if (!r || s.finished > static_cast<std::int64_t>(finished.size())) return std::nullopt;
      r->restore_state(s.state, Impl::observations_of(finished, static_cast<std::size_t>(s.finished)));
      return r->save_state();
    } catch (const Error&) {
      return std::nullopt;
    }
  };
  auto compare = [&](std::int64_t told, std::int64_t outstanding) {
    if (!resumable) return true;
    for (const auto& s : states) {
      if (s.finished != told || s.outstanding != outstanding) continue;
      const std::optional<std::string> now = resumable->save_state();
      ++rep.states_compared;
      if (now && *now == s.state) continue;
      if (now && as_saved_now(s) == now) continue;
      rep.divergence = fmt::format("the saved algorithm state after {} result(s){} differs from the replayed one {}",
                                   told, outstanding >= 0 ? fmt::format(" and the ask of trial {}", outstanding) : "",
                                   now ? first_difference(s.state, *now) : "(the replayed algorithm saves none)");
      return false;
    }
    return true;
  };
  if (!compare(0, -1)) return rep;
  for (std::size_t i = 0; i < finished.size(); ++i) {
    const TrialRecord& t = finished[i];
    const std::vector<Suggestion> s = alg->ask(1);
    ++rep.replayed;
    const bool serial =
        t.batch_size == 1 && t.pending_before == 0 && t.finished_before == static_cast<std::int64_t>(i);
    if (serial) {
      const bool same = s.size() == 1 && s[0].x.size() == t.x.size() &&
                        (m.trial_x(s[0].x) - t.x).cwiseAbs().maxCoeff() <= kReplayTolerance;
      if (!same) {
        rep.divergence = fmt::format(
            "trial {} (result {} in finish order): the replay suggests {} instead of the stored {}", t.id, i,
            s.empty() ? std::string("nothing") : join_numbers(m.theta_of(m.trial_x(s[0].x))),
            join_numbers(t.theta));
        return rep;
      }
    }
    if (!compare(static_cast<std::int64_t>(i), t.id)) return rep;
    alg->tell({observation_of(t)});
    if (!compare(static_cast<std::int64_t>(i) + 1, -1)) return rep;
  }
  return rep;
}

}  // namespace varbo
