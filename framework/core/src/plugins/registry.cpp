#include "varbo/registry.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <regex>
#include <cctype>
#include <map>
#include <mutex>
#include <set>
#include <shared_mutex>

#include "../config/kind_text.hpp"
#include "on_demand.hpp"
#include "varbo/errors.hpp"
#include "varbo/loader.hpp"
#include "varbo/text.hpp"

namespace varbo {

namespace detail {
namespace {
std::mutex& demand_table_mutex() {
  static std::mutex m;
  return m;
}
std::map<const Registry*, DemandFn>& demand_table() {
  static auto* t = new std::map<const Registry*, DemandFn>();  // leaked: registries may outlive static teardown
  return *t;
}
}  // namespace

void set_on_demand(const Registry& registry, DemandFn load) {
  std::lock_guard<std::mutex> lock(demand_table_mutex());
  if (load)
    demand_table()[&registry] = std::move(load);
  else
    demand_table().erase(&registry);
}

bool demand(const Registry& registry, const std::string& name) {
  DemandFn load;
  {
    std::lock_guard<std::mutex> lock(demand_table_mutex());
    if (demand_table().empty()) return false;
    const auto it = demand_table().find(&registry);
    if (it == demand_table().end()) return false;
    load = it->second;
  }
  load(name);  // outside the table's lock: loading a library registers components
  return true;
}
}  // namespace detail

namespace {
/// Guards every Registry's component list: a registry that plugins fill on demand may be shared by the Study
/// objects of several threads (Study::open keeps one per plugin path for the process, study_plugins.cpp), and a
/// lookup in one thread may load a library, adding components, while another thread reads the list. Readers
/// share it; add() takes it alone. Never held while a library loads (demand runs before the lock is taken),
/// so a plugin's registration cannot deadlock on it. One lock for all registries: they change only when a
/// library loads. Kept out of the class so that its layout, which plugins compile against, is unchanged.
std::shared_mutex& items_mutex() {
  static std::shared_mutex m;
  return m;
}
}  // namespace

YAML::Node ResolvedComponent::resolved() const {
  YAML::Node out(YAML::NodeType::Map);
  out["type"] = info ? info->name : std::string("?");
  YAML::Node opts = options.resolved();
  for (const auto& kv : opts) out[kv.first] = kv.second;
  return out;
}

void PluginRegistrar::add(ComponentInfo info) {
  info.plugin = plugin_;
  info.library = library_;
  registry_.add(std::move(info));
}

namespace {
/// A component name is the second half of "plugin/name" and a word of the plugin index and of YAML: letters,
/// digits, '_', '-', '.' (as a plugin name), so that `type: my acq/v2` cannot be registered and never found.
void check_component_name(const ComponentInfo& info) {
  if (info.name.empty()) throw PluginLoadError("a component has an empty name");
  if (info.name.size() > 128)
    throw PluginLoadError(fmt::format("{} name '{}...' is longer than 128 characters", kind_name(info.kind),
                                      safe_text(info.name, 40)));
  for (const char ch : info.name)
    if (!(ascii_alnum(ch) || ch == '_' || ch == '-' || ch == '.'))
      throw PluginLoadError(fmt::format("{} name '{}' has a character other than ASCII letters, digits, '_', '-', '.'",
                                        kind_name(info.kind), printable(info.name)));
}

/// Option declarations are checked when the plugin loads, not when a config uses them: an option named `type`
/// was written next to the component's `type:` into config.resolved.yaml and the stored study, which then no
/// longer parsed ("duplicate key 'type'"); a repeated option was listed twice by --describe.
void check_option_names(const ComponentInfo& info) {
  std::set<std::string> seen;
  for (const OptionSpec& o : info.options) {
    if (o.name.empty())
      throw PluginLoadError(fmt::format("{} '{}' declares an option with an empty name", kind_name(info.kind),
                                        info.name));
    if (o.name == "type")
      throw PluginLoadError(fmt::format("{} '{}' declares an option named 'type', which names the component itself "
                                        "in a configuration ({{type: {}, ...}}); rename the option",
                                        kind_name(info.kind), info.name, info.name));
    if (!seen.insert(o.name).second)
      throw PluginLoadError(fmt::format("{} '{}' declares the option '{}' twice", kind_name(info.kind), info.name,
                                        printable(o.name)));
    if (const std::string why = option_default_problem(o); !why.empty())
      throw PluginLoadError(fmt::format("{} '{}' declares the option '{}': {}", kind_name(info.kind), info.name,
                                        printable(o.name), why));
  }
}
}  // namespace

void Registry::remove_library(const std::string& library) {
  std::unique_lock<std::shared_mutex> lock(items_mutex());
  items_.erase(std::remove_if(items_.begin(), items_.end(), [&](const auto& c) { return c->library == library; }),
               items_.end());
}

void Registry::add(ComponentInfo info) {
  check_component_name(info);
  check_option_names(info);
  if (static_cast<std::size_t>(info.factory.index()) != static_cast<std::size_t>(info.kind))
    throw PluginLoadError(fmt::format("component '{}' declares kind {} but its factory makes another kind",
                                      info.name, kind_name(info.kind)));
  std::unique_lock<std::shared_mutex> lock(items_mutex());
  for (const auto& c : items_)
    if (c->kind == info.kind && c->full_name() == info.full_name())
      throw PluginLoadError(fmt::format("{} '{}' is registered twice (by {} and {})", kind_name(info.kind),
                                        info.full_name(), c->library, info.library));
  items_.push_back(std::make_unique<ComponentInfo>(std::move(info)));
}

const ComponentInfo* Registry::try_find(Kind kind, const std::string& name) const {
  // With plugins on demand: first the libraries providing `name`, so that it resolves as with every plugin
  // loaded; when it is still unknown (a stale index?), every library, and a second look.
  const bool on_demand = detail::demand(*this, name);
  for (int pass = 0; pass < (on_demand ? 2 : 1); ++pass) {
    if (pass == 1) detail::demand(*this, "");
    std::shared_lock<std::shared_mutex> lock(items_mutex());
    const ComponentInfo *found = nullptr, *builtin = nullptr;
    int matches = 0, builtin_matches = 0;
    for (const auto& c : items_) {
      if (c->kind != kind) continue;
      if (c->full_name() == name) return c.get();
      if (c->name == name) {
        found = c.get();
        ++matches;
        if (is_builtin(*c)) {
          builtin = c.get();
          ++builtin_matches;
        }
      }
    }
    // Built-in first (loader.hpp): a default such as `acquisition: ei` must keep meaning varbo's ei whatever
    // third-party plugin is installed; only the full name "plugin/ei" reaches theirs.
    if (builtin_matches == 1) return builtin;
    if (matches == 1) return found;
  }
  return nullptr;
}

const ComponentInfo& Registry::find(Kind kind, const std::string& name, const ConfigNode* where) const {
  if (const ComponentInfo* c = try_find(kind, name)) return *c;
  std::vector<std::string> known, ambiguous;
  std::shared_lock<std::shared_mutex> lock(items_mutex());
  for (const auto& c : items_) {
    if (c->kind != kind) continue;
    known.push_back(c->name);
    if (c->name == name) ambiguous.push_back(c->full_name());
  }
  std::string msg;
  if (!ambiguous.empty()) {
    msg = fmt::format("{} name '{}' is ambiguous; use one of: {}", kind_name(kind), name, join(ambiguous));
  } else {
    std::sort(known.begin(), known.end());
    known.erase(std::unique(known.begin(), known.end()), known.end());
    const std::string near = closest_match(name, known);
    // safe_text: a 10 MB name gave a 10 MB message (and, before closest_match's limit, a minute of edit distances).
    msg = fmt::format("unknown {} '{}'. Known: {}{}", kind_name(kind), safe_text(name, 40),
                      known.empty() ? "(none loaded; check the plugin path)" : join(known),
                      near.empty() ? "" : "; did you mean '" + near + "'?");
    // The task `python` exists only where a Python program provides the objective (host_task.cpp): say so rather
    // than list the benchmarks as if the user had misspelled one.
    if (kind == Kind::Task && name == "python")
      msg = "the task 'python' is a function of a Python program: run it with varbo.minimize(...) or ask/tell "
            "from Python (docs/python.md); `varbo run` cannot call it (tasks here: " + join(known) + ")";
  }
  lock.unlock();
  if (where) {
    try {
      where->fail(msg);
    } catch (const ConfigError& e) {
      throw UnknownComponentError(e.what());
    }
  }
  throw UnknownComponentError(msg);
}

std::vector<const ComponentInfo*> Registry::components(Kind kind) const {
  detail::demand(*this, "");
  std::vector<const ComponentInfo*> out;
  std::shared_lock<std::shared_mutex> lock(items_mutex());
  for (const auto& c : items_)
    if (c->kind == kind) out.push_back(c.get());
  std::sort(out.begin(), out.end(), [](auto* a, auto* b) { return a->full_name() < b->full_name(); });
  return out;
}

std::vector<const ComponentInfo*> Registry::all() const {
  detail::demand(*this, "");
  std::vector<const ComponentInfo*> out;
  {
    std::shared_lock<std::shared_mutex> lock(items_mutex());
    for (const auto& c : items_) out.push_back(c.get());
  }
  std::sort(out.begin(), out.end(), [](auto* a, auto* b) {
    return std::make_pair(static_cast<int>(a->kind), a->full_name()) <
           std::make_pair(static_cast<int>(b->kind), b->full_name());
  });
  return out;
}

ResolvedComponent Registry::resolve(Kind kind, const ConfigNode& node) const {
  std::string type;
  ConfigNode type_node = node;
  if (node.is_scalar()) {
    type = node.scalar();
  } else if (node.is_map()) {
    if (!node.has("type"))
      node.fail(fmt::format("missing 'type:' naming the {}", kind_name(kind)));
    type_node = node.child("type");
    if (!type_node.is_scalar()) type_node.fail(fmt::format("expected {} name", kind_with_article(kind)));
    type = type_node.scalar();
  } else {
    node.fail(fmt::format("expected {} name or a map with 'type:' and its options", kind_with_article(kind)));
  }
  const ComponentInfo& info = find(kind, type, &type_node);
  // The bare-name form (`task: external`) cannot give a required option: say which, at the name, in the map
  // form to write (before: "<none>: missing required key for task 'external'", no position, no key).
  if (node.is_scalar())
    for (const OptionSpec& o : info.options)
      if (o.required)
        node.fail(fmt::format("{} '{}' needs the key '{}' ({}): write it as a map, {{type: {}, {}: ...}}",
                              kind_name(kind), info.name, o.name, o.expected(), type, o.name));
  ResolvedComponent rc;
  rc.info = &info;
  rc.source = node;
  rc.options = validate_options(node.is_map() ? node : ConfigNode(), info.options,
                                fmt::format("{} '{}'", kind_name(kind), info.name), this);
  return rc;
}

void throw_factory_error(const ResolvedComponent& c, const std::exception& e) {
  const ComponentInfo& info = *c.info;
  const std::string origin = info.library.empty() ? std::string() : fmt::format(" (from {})", info.library);
  c.source.fail(fmt::format("{} '{}'{} could not be created: {}", kind_name(info.kind), info.full_name(), origin,
                            e.what()));
}

void rethrow_with_position(const ResolvedComponent& c, const Error& e) {
  // A position is "NAME:LINE:COL: " at the start (ConfigNode::fail): a file name, then two numbers.
  const std::string m = e.what();
  static const std::regex positioned(R"(^[^\n]*?:\d+:\d+: )");
  if (std::regex_search(m, positioned)) throw;
  throw_factory_error(c, e);
}

bool compatible(const std::vector<const ComponentInfo*>& parts, std::string* why) {
  for (std::size_t i = 0; i < parts.size(); ++i) {
    for (const auto& req : parts[i]->needs) {
      bool met = false;
      for (std::size_t j = 0; j < parts.size() && !met; ++j) {
        if (j == i) continue;
        met = std::find(parts[j]->provides.begin(), parts[j]->provides.end(), req) != parts[j]->provides.end();
      }
      if (!met) {
        if (why) *why = fmt::format("{} '{}' requires '{}'", kind_name(parts[i]->kind), parts[i]->name, req);
        return false;
      }
    }
  }
  return true;
}

}  // namespace varbo
