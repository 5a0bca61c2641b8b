#pragma once
// Finds and loads plugin libraries. Handles are never closed (components may outlive any scope).
#include <string>
#include <vector>
#include "varbo/registry.hpp"

namespace varbo {

struct LoadedLibrary {
  std::string path, name, version, fingerprint, description;
};
struct SkippedLibrary {
  std::string path, reason;
};

class PluginLoader {
 public:
  explicit PluginLoader(Registry& registry) : registry_(registry) {}
  /// Loads one library; throws PluginLoadError (or PluginVersionError) naming the file and the reason.
  void load_file(const std::string& path);
  /// Loads every libvarbo_*.so in `dir`; failures are recorded in skipped() (and logged), not thrown.
  void load_directory(const std::string& dir);
  /// Loads `extra` (files or directories), then VARBO_PLUGIN_PATH, then the directory next to
  /// libvarbo_core (…/lib/varbo/plugins), then the install directory. A plugin name seen twice is
  /// loaded once (first wins).
  void load_default(const std::vector<std::string>& extra = {});
  const std::vector<LoadedLibrary>& loaded() const { return loaded_; }
  const std::vector<SkippedLibrary>& skipped() const { return skipped_; }
  static std::vector<std::string> search_path(const std::vector<std::string>& extra = {});

 private:
  Registry& registry_;
  std::vector<LoadedLibrary> loaded_;
  std::vector<SkippedLibrary> skipped_;
};

/// A registry with every plugin on the default search path loaded (one per process; thread-safe init).
Registry& default_registry();
const PluginLoader& default_loader();

}  // namespace varbo
