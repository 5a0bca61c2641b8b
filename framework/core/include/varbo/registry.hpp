#pragma once
// The registry of components. Plugins add ComponentInfo entries; configs resolve and create them by name.
#include <functional>
#include <memory>
#include <new>
#include <optional>
#include <string>
#include <variant>
#include <vector>
#include "varbo/acquisition.hpp"
#include "varbo/algorithm.hpp"
#include "varbo/errors.hpp"
#include "varbo/kernel.hpp"
#include "varbo/optimizer.hpp"
#include "varbo/options.hpp"
#include "varbo/region.hpp"
#include "varbo/sampler.hpp"
#include "varbo/surrogate.hpp"
#include "varbo/task.hpp"

namespace varbo {

class Registry;

/// What a factory knows besides its own options.
struct BuildContext {
  const Registry* registry = nullptr;
  Index dim = 0;                    ///< problem dimension (0 for tasks, which define it)
  std::uint64_t seed = 0;
  Index budget = 0;                 ///< total evaluations (algorithms)
  std::optional<Vec> initial_point; ///< θ0 in the unit cube, when the task or config gives one
};

template <class T>
using Factory = std::function<std::unique_ptr<T>(const Options&, const BuildContext&)>;
using AnyFactory = std::variant<Factory<Surrogate>, Factory<Acquisition>, Factory<RegionConstraint>,
                                Factory<Sampler>, Factory<Optimizer>, Factory<Task>, Factory<Algorithm>,
                                Factory<Kernel>>;

template <class T> constexpr Kind kind_of();
template <> constexpr Kind kind_of<Surrogate>() { return Kind::Surrogate; }
template <> constexpr Kind kind_of<Acquisition>() { return Kind::Acquisition; }
template <> constexpr Kind kind_of<RegionConstraint>() { return Kind::Region; }
template <> constexpr Kind kind_of<Sampler>() { return Kind::Sampler; }
template <> constexpr Kind kind_of<Optimizer>() { return Kind::Optimizer; }
template <> constexpr Kind kind_of<Task>() { return Kind::Task; }
template <> constexpr Kind kind_of<Algorithm>() { return Kind::Algorithm; }
template <> constexpr Kind kind_of<Kernel>() { return Kind::Kernel; }

/// Base of the optional interfaces a component offers beyond its kind's, e.g. RunContinuation
/// (varbo/continuation.hpp). The host asks for one with ComponentInfo::extension<T>(), so the framework
/// never needs to know which concrete component offers it.
class ComponentExtension {
 public:
  virtual ~ComponentExtension();
};

/// A component as declared by its plugin. `provides`/`needs` are capability tags (docs/plugins.md);
/// the all-combinations suite skips only combinations whose tags do not match.
struct ComponentInfo {
  std::string name;         ///< short name, e.g. "ei"
  Kind kind = Kind::Surrogate;
  std::string description;
  std::vector<OptionSpec> options;
  std::vector<std::string> provides;
  std::vector<std::string> needs;
  AnyFactory factory;
  std::vector<std::shared_ptr<const ComponentExtension>> extensions;  ///< optional interfaces (see above)
  std::string plugin;       ///< plugin name (filled by the registry)
  std::string library;      ///< file it came from (filled by the registry)
  std::string full_name() const { return plugin.empty() ? name : plugin + "/" + name; }
  /// The extension of type T this component offers, or nullptr.
  template <class T>
  const T* extension() const {
    for (const auto& e : extensions)
      if (const T* t = dynamic_cast<const T*>(e.get())) return t;
    return nullptr;
  }
};

template <class T>
ComponentInfo make_component(std::string name, std::string description, std::vector<OptionSpec> options,
                             Factory<T> factory, std::vector<std::string> provides = {},
                             std::vector<std::string> needs = {}) {
  ComponentInfo info;
  info.name = std::move(name);
  info.kind = kind_of<T>();
  info.description = std::move(description);
  info.options = std::move(options);
  info.provides = std::move(provides);
  info.needs = std::move(needs);
  info.factory = std::move(factory);
  return info;
}

/// A component chosen by a config, with validated options.
struct ResolvedComponent {
  const ComponentInfo* info = nullptr;
  Options options;
  ConfigNode source;
  YAML::Node resolved() const;  ///< {type: name, ...options with defaults}
};

/// A factory that refused its options with a standard exception: throws ConfigError at the component's
/// position in the config, naming the component, its plugin and the exception's message (exit 2, not an
/// "internal error").
[[noreturn]] void throw_factory_error(const ResolvedComponent& c, const std::exception& e);
/// Called in the handler of a varbo Error from a factory: rethrows it as it is when its message says where
/// ("file:line:col: ..."), else (a bare ConfigError or InputError from a third-party factory) throws it again as
/// throw_factory_error does, with the component's position and name.
[[noreturn]] void rethrow_with_position(const ResolvedComponent& c, const Error& e);

class Registry {
 public:
  Registry() = default;
  Registry(const Registry&) = delete;
  Registry& operator=(const Registry&) = delete;

  /// Adds a component with the origin (plugin, library) it carries; plugins add through their
  /// PluginRegistrar, which sets both.
  void add(ComponentInfo info);
  /// Looks up by full name "plugin/name" or unique short name. Unknown names throw UnknownComponentError
  /// listing the known ones; `where` gives the position for the message.
  const ComponentInfo& find(Kind kind, const std::string& name, const ConfigNode* where = nullptr) const;
  const ComponentInfo* try_find(Kind kind, const std::string& name) const;
  std::vector<const ComponentInfo*> components(Kind kind) const;
  std::vector<const ComponentInfo*> all() const;
  /// Removes every component `library` added: a plugin whose registration failed part-way is not loaded, so
  /// none of its components may stay usable.
  void remove_library(const std::string& library);

  /// Resolves `node` (a name, or a map with `type:` and options) into a validated component.
  ResolvedComponent resolve(Kind kind, const ConfigNode& node) const;

  template <class T>
  std::unique_ptr<T> create(const ResolvedComponent& c, const BuildContext& ctx) const {
    if (c.info == nullptr || c.info->kind != kind_of<T>())
      throw std::logic_error("Registry::create: component kind mismatch");
    BuildContext local = ctx;
    local.registry = this;
    std::unique_ptr<T> made;
    try {
      made = std::get<Factory<T>>(c.info->factory)(c.options, local);
    } catch (const Error& e) {
      // Already says where (ConfigError from o.node("key").fail(...), a nested component, ...); a bare one from a
      // third-party factory (`throw ConfigError("weight must be positive")`) gets the position and component.
      rethrow_with_position(c, e);
    } catch (const std::bad_alloc&) {
      throw;
    } catch (const std::exception& e) {
      throw_factory_error(c, e);  // e.g. std::invalid_argument from a third-party factory
    } catch (...) {  // `throw 7` in a third-party factory ended the process (std::terminate)
      throw_factory_error(c, std::runtime_error("it threw something that is not a std::exception"));
    }
    // A factory's null pointer was used as the component: a segfault after the initial design's trials.
    if (!made) throw_factory_error(c, std::runtime_error("its factory returned no object (a null pointer)"));
    return made;
  }
  /// Convenience: resolve YAML text such as "{type: ei, xi: 0.1}" and create.
  template <class T>
  std::unique_ptr<T> create(const std::string& yaml, const BuildContext& ctx) const {
    return create<T>(resolve(kind_of<T>(), ConfigNode::parse(yaml, "<inline>")), ctx);
  }

 private:
  std::vector<std::unique_ptr<ComponentInfo>> items_;
};

/// The handle a plugin registers through (the `registry` of VARBO_PLUGIN): it can only add components, and
/// every component it adds is recorded under the plugin's own name and library file, whatever the
/// ComponentInfo says. A plugin never sees the Registry, so it cannot register under another plugin's name or
/// touch other plugins' components.
class PluginRegistrar {
 public:
  PluginRegistrar(Registry& registry, std::string plugin, std::string library)
      : registry_(registry), plugin_(std::move(plugin)), library_(std::move(library)) {}
  PluginRegistrar(const PluginRegistrar&) = delete;
  PluginRegistrar& operator=(const PluginRegistrar&) = delete;

  void add(ComponentInfo info);
  const std::string& plugin() const { return plugin_; }

 private:
  Registry& registry_;
  std::string plugin_, library_;
};

/// True when every `needs` tag of each component is in the union of the others' `provides`.
/// On false, `why` (if non-null) names the first unmet requirement.
bool compatible(const std::vector<const ComponentInfo*>& parts, std::string* why = nullptr);

}  // namespace varbo
