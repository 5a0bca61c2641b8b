#pragma once
// Finds and loads plugin libraries. Handles are never closed (components may outlive any scope).
#include <mutex>
#include <string>
#include <vector>
#include "varbo/registry.hpp"

namespace varbo {

struct LoadedLibrary {
  std::string path, name, version, fingerprint, description;
  bool builtin = false;  ///< from varbo's own plugin folder (next to libvarbo_core, or the install folder)
};
struct SkippedLibrary {
  std::string path, reason;
};

class PluginLoader {
 public:
  explicit PluginLoader(Registry& registry) : registry_(registry) {}
  ~PluginLoader();
  PluginLoader(const PluginLoader&) = delete;
  PluginLoader& operator=(const PluginLoader&) = delete;
  /// Built-in plugins on demand (a process opening a study: `varbo suggest`, docs/studies.md): when every
  /// built-in folder has a current index (which library provides which component names, kept in the folder by
  /// a process that loaded it in full), load_default() loads none of their libraries; the registry loads the
  /// libraries providing a name when the name is first looked up, and all of them before a listing or when a
  /// name is unknown, so every lookup resolves as with everything loaded. Each library still passes every
  /// check of load_file() before any of its code runs. Third-party plugins (`extra`, VARBO_PLUGIN_PATH) load
  /// at once, with the built-in libraries providing their components' short names (built-in first).
  void set_on_demand(bool on) { on_demand_ = on; }
  /// Metadata only: every check that needs no plugin code (ELF, the .varbo_meta section: ABI, API,
  /// fingerprint, name, duplicates) is made and loaded() lists the libraries that pass, but none is dlopen'ed,
  /// so no plugin code runs and no component is registered (`varbo plugins --libraries`).
  void set_metadata_only(bool on) { metadata_only_ = on; }
  /// Loads one third-party library; throws PluginLoadError (or PluginVersionError) naming the file and the
  /// reason. The file is checked (regular file, ELF64 for this machine, every segment inside the file) before
  /// dlopen sees it.
  void load_file(const std::string& path);
  /// Loads every libvarbo_*.so in `dir`; failures (including symlink loops and unreadable entries) are
  /// recorded in skipped() and logged as warnings, not thrown.
  void load_directory(const std::string& dir);
  /// Loads the built-in plugins (the folder next to libvarbo_core, …/lib/varbo/plugins, then the install
  /// folder), then `extra` (files or folders, e.g. a study's plugin_path), then VARBO_PLUGIN_PATH. A plugin
  /// name seen twice is loaded once (first wins, so built-ins cannot be replaced; a warning names both
  /// files). A missing `extra` or VARBO_PLUGIN_PATH entry is a warning naming it. A third-party component
  /// whose short name is a built-in one's gets a warning: the short name keeps meaning the built-in one.
  void load_default(const std::vector<std::string>& extra = {});
  const std::vector<LoadedLibrary>& loaded() const { return loaded_; }
  const std::vector<SkippedLibrary>& skipped() const { return skipped_; }
  /// Third-party components reachable only by their full name (their short name is a built-in one).
  const std::vector<const ComponentInfo*>& shadowed() const { return shadowed_; }
  static std::vector<std::string> search_path(const std::vector<std::string>& extra = {});
  static std::vector<std::string> builtin_path();
  static std::vector<std::string> env_path();  ///< VARBO_PLUGIN_PATH, split at ':'

 private:
  void load_file(const std::string& path, bool builtin);
  void load_directory(const std::string& dir, bool builtin);
  void skip(const std::string& path, const std::string& reason);
  bool defer_builtin_folders(const std::vector<std::string>& folders);
  void index_builtin_folder(const std::string& dir);
  /// Loads the deferred libraries providing `name` (a short name, or "plugin/name"); all of them for "".
  void demand(const std::string& name);

  struct DeferredLibrary {
    std::string path, plugin;
    std::vector<std::string> components;
    bool done = false;
  };

  Registry& registry_;
  bool metadata_only_ = false;
  bool on_demand_ = false;
  std::vector<DeferredLibrary> deferred_;
  std::recursive_mutex demand_mutex_;
  std::vector<LoadedLibrary> loaded_;
  std::vector<SkippedLibrary> skipped_;
  std::vector<const ComponentInfo*> shadowed_;
};

/// True for a component of a plugin shipped with varbo: its library lies in one of
/// PluginLoader::builtin_path()'s folders. A short name resolves to the built-in component when one has it.
bool is_builtin(const ComponentInfo& c);
/// Components of third-party plugins whose short name is also a built-in component's (of the same kind):
/// each is reachable only by its full name "plugin/name".
std::vector<const ComponentInfo*> shadowed_by_builtin(const Registry& registry);

/// A registry with every plugin on the default search path loaded (one per process; thread-safe init).
Registry& default_registry();
const PluginLoader& default_loader();

}  // namespace varbo
