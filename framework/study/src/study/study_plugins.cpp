// The plugins of the studies a process opens: one registry and loader per plugin path, shared by every
// Study::open with that path, and the stored identities already checked with them.
#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <mutex>
#include <set>
#include <tuple>

#include "study_impl.hpp"
#include "varbo/host_task.hpp"

namespace fs = std::filesystem;

namespace varbo {

/// `on_demand`: a study being opened loads only the built-in plugins its configuration looks up (loader.hpp);
/// `varbo suggest` pays for two or three libraries, not every one installed.
std::unique_ptr<Study::Impl> impl_with_plugins(const std::vector<std::string>& paths, bool on_demand) {
  auto impl = std::make_unique<Study::Impl>();
  impl->own_registry = std::make_unique<Registry>();
  impl->loader = std::make_unique<PluginLoader>(*impl->own_registry);
  impl->loader->set_on_demand(on_demand);
  impl->loader->load_default(paths);
  return impl;
}

namespace {

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


}  // namespace

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
    // The task `python` as a domain (box or `parameters:`) evaluated elsewhere: a study varbo.minimize wrote, or
    // one created for ask/tell from Python, opens for suggest, observe, worker and verify (the function itself is
    // the Python module's, inside minimize only).
    add_host_python_task(plugins->registry);
    it = cache->emplace(key, std::move(plugins)).first;
  }
  return it->second->registry;
}

namespace {
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
}  // namespace

bool identity_checked(const Registry& registry, const std::string& text, const std::string& identity) {
  std::lock_guard<std::mutex> lock(identity_mutex());
  return identities_checked().count({&registry, text, identity}) > 0;
}
void remember_identity(const Registry& registry, const std::string& text, const std::string& identity) {
  std::lock_guard<std::mutex> lock(identity_mutex());
  identities_checked().insert({&registry, text, identity});
}

}  // namespace varbo
