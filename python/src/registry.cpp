// varbo.plugins(), varbo.describe(), varbo.load_plugin(), varbo.set_log_level(): the registry seen from Python.
#include <fmt/format.h>

#include <cstdlib>
#include <filesystem>
#include <memory>

#include "common.hpp"
#include "varbo/errors.hpp"
#include "varbo/loader.hpp"
#include "varbo/log.hpp"
#include "varbo/study.hpp"

namespace varbo::python {

namespace {

struct ModuleRegistry {
  Registry registry;
  PluginLoader loader{registry};
  // With the task `python` (minimize's): varbo.describe("python") and varbo.plugins("task") listed it nowhere
  // though docs/python.md configures it (red team, session 23).
  ModuleRegistry() {
    loader.load_default();
    add_python_task(registry);
  }
};

ModuleRegistry& instance() {
  static ModuleRegistry* r = new ModuleRegistry();  // never destroyed: plugin code may outlive any scope
  return *r;
}

py::dict option_dict(const OptionSpec& o) {
  py::dict d;
  d["name"] = o.name;
  d["type"] = type_name(o.type);
  d["default"] = o.required ? py::object(py::none()) : py::object(py::str(o.default_yaml));
  d["required"] = o.required;
  d["description"] = o.description;
  d["expects"] = o.expected();
  if (!o.choices.empty()) d["choices"] = o.choices;
  return d;
}

py::dict component_dict(const ComponentInfo& c, bool with_options) {
  py::dict d;
  d["name"] = c.name;
  d["full_name"] = c.full_name();
  d["kind"] = kind_name(c.kind);
  d["plugin"] = c.plugin;
  d["library"] = c.library;
  d["builtin"] = is_builtin(c);
  d["description"] = c.description;
  d["provides"] = c.provides;
  d["needs"] = c.needs;
  if (with_options) {
    py::list opts;
    for (const auto& o : c.options) opts.append(option_dict(o));
    d["options"] = opts;
  }
  return d;
}

constexpr Kind kKinds[] = {Kind::Task, Kind::Algorithm, Kind::Surrogate, Kind::Acquisition,
                           Kind::Region, Kind::Sampler, Kind::Optimizer, Kind::Kernel};

}  // namespace

const Registry& module_registry() { return instance().registry; }

void load_plugin(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec))
    throw InputError(fmt::format("load_plugin: {}: does not exist; expected a plugin file (libvarbo_NAME.so)", path));
  const std::string full = std::filesystem::absolute(path).string();
  instance().loader.load_file(full);
  const char* old = std::getenv("VARBO_PLUGIN_PATH");
  const std::string value = old && *old ? std::string(old) + ":" + full : full;
  ::setenv("VARBO_PLUGIN_PATH", value.c_str(), 1);
}

void bind_registry(py::module_& m) {
  m.def(
      "plugins",
      [](std::optional<std::string> kind) {
        py::list out;
        const Registry& r = module_registry();
        for (Kind k : kKinds) {
          if (kind && kind_name(k) != *kind) continue;
          for (const auto* c : r.components(k)) out.append(component_dict(*c, false));
        }
        if (kind && out.empty()) {
          bool known = false;
          for (Kind k : kKinds) known = known || kind_name(k) == *kind;
          if (!known) kind_from_name(*kind);  // throws ConfigError listing the kinds
        }
        return out;
      },
      py::arg("kind") = py::none(),
      "Every loaded component (optionally of one kind: 'task', 'algorithm', 'surrogate', ...), as dicts with name, full_name, "
      "kind, plugin, library, builtin, description, provides and needs.");
  m.def(
      "describe",
      [](const std::string& name) -> py::dict {
        if (name == "study") {
          py::dict d;
          d["name"] = "study";
          d["kind"] = "study";
          d["description"] = "the top-level keys of a study configuration";
          py::list opts;
          for (const auto& o : study_options()) opts.append(option_dict(o));
          d["options"] = opts;
          return d;
        }
        const Registry& r = module_registry();
        for (Kind k : kKinds)
          if (const ComponentInfo* c = r.try_find(k, name)) return component_dict(*c, true);
        std::vector<std::string> names;
        for (const auto* c : r.all()) names.push_back(c->name);
        const std::string near = closest_match(name, names);
        throw UnknownComponentError(fmt::format("no component named '{}'{}", name,
                                                near.empty() ? "" : "; did you mean '" + near + "'?"));
      },
      py::arg("name"),
      "One component (a name or plugin/name; 'study' for the top-level keys) with its options: each a dict with "
      "name, type, default (YAML text; None when required), required, description and expects.");
  m.def(
      "load_plugin", [](const std::string& path) { load_plugin(path); }, py::arg("path"),
      "Loads a third-party plugin library (libvarbo_NAME.so) into this process: its components appear in "
      "plugins(), fit() and the Optuna sampler, and studies created or opened afterwards find it (it is appended to "
      "VARBO_PLUGIN_PATH). Raises PluginLoadError naming the file and the reason.");
  m.def(
      "skipped_plugins",
      [] {
        py::list out;
        module_registry();
        for (const auto& s : instance().loader.skipped()) out.append(py::make_tuple(s.path, s.reason));
        return out;
      },
      "Plugin libraries found on the search path but not loaded, as (path, reason).");
  m.def(
      "set_log_level",
      [](const std::string& level) {
        static const std::pair<const char*, LogLevel> levels[] = {{"debug", LogLevel::Debug},
                                                                  {"info", LogLevel::Info},
                                                                  {"warn", LogLevel::Warn},
                                                                  {"error", LogLevel::Error},
                                                                  {"quiet", LogLevel::Quiet}};
        for (const auto& [n, l] : levels)
          if (level == n) return set_log_level(l);
        throw InputError(fmt::format("set_log_level: unknown level '{}'; expected debug, info, warn, error or quiet",
                                     level));
      },
      py::arg("level"), "Level of varbo's log messages on stderr: 'debug', 'info' (default), 'warn', 'error', 'quiet'.");
}

}  // namespace varbo::python
