#include "varbo/loader.hpp"

#include <dlfcn.h>
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <mutex>
#include <optional>
#include <set>

#include "elf_check.hpp"
#include "on_demand.hpp"
#include "plugin_index.hpp"
#include "plugin_meta.hpp"
#include "varbo/errors.hpp"
#include "varbo/log.hpp"
#include "varbo/plugin.hpp"
#include "varbo/text.hpp"

#ifndef VARBO_INSTALL_PLUGIN_DIR
#define VARBO_INSTALL_PLUGIN_DIR ""
#endif

namespace fs = std::filesystem;

namespace varbo {

const char* host_fingerprint() { return VARBO_BUILD_FINGERPRINT; }

namespace {

/// A plugin name is the first half of every qualified component name ("plugin/name"): it must be printable
/// and free of the separator.
std::string bad_plugin_name(const char* name) {
  if (name == nullptr) return "its plugin info gives no name (NULL)";
  const std::string n = name;
  if (n.empty()) return "its plugin info gives an empty name";
  if (n.size() > 128) return "its plugin name is longer than 128 characters";
  for (unsigned char ch : n)
    if (!(std::isalnum(ch) || ch == '_' || ch == '-' || ch == '.')) {
      const bool printable = std::all_of(n.begin(), n.end(), [](unsigned char c) { return c >= 0x20 && c < 0x7f; });
      return fmt::format("its plugin name {}has a character other than letters, digits, '_', '-', '.'",
                         printable ? "'" + n + "' " : "");
    }
  return "";
}

}  // namespace

void PluginLoader::load_file(const std::string& path) { load_file(path, false); }

void PluginLoader::load_file(const std::string& path, bool builtin) {
  // Size, class, machine and every segment are checked first: dlopen maps a truncated file and dies with
  // SIGBUS on the first page past its end, and says "No such file or directory" for another architecture.
  detail::check_elf_file(path);
  // Then the plugin's identity, read from its ".varbo_meta" section without loading it: a plugin built for
  // another ABI, API or build runs no code at all, not even its static initializers (varbo/plugin.hpp).
  const std::optional<detail::PluginMeta> meta = detail::read_plugin_meta(path);
  if (!meta)
    throw PluginLoadError(fmt::format(
        "{}: not a varbo plugin of ABI {} (no {} section; a plugin built for ABI 3 or older has none either: "
        "build it with VARBO_PLUGIN and varbo_add_plugin against this varbo SDK)",
        path, VARBO_ABI_VERSION, VARBO_PLUGIN_META_SECTION));
  const varbo_plugin_meta& info = meta->block;
  const std::string shown_name = meta->complete() ? info.name : "?";
  if (info.abi_version != VARBO_ABI_VERSION)
    throw PluginVersionError(fmt::format("{}: plugin '{}' was built for plugin ABI {}, host is ABI {}; rebuild it "
                                         "against this varbo SDK",
                                         path, shown_name, info.abi_version, VARBO_ABI_VERSION));
  if (!meta->complete())
    throw PluginVersionError(fmt::format("{}: plugin metadata block of {} bytes (section of {}) or with unterminated "
                                         "strings, host expects {} bytes; rebuild it against this varbo SDK",
                                         path, info.struct_size, meta->section_size, sizeof(varbo_plugin_meta)));
  if (info.api_version != VARBO_API_VERSION)
    throw PluginVersionError(fmt::format("{}: plugin '{}' uses API version {}, host is {}", path, shown_name,
                                         info.api_version, VARBO_API_VERSION));
  const std::string fp = info.fingerprint;
  if (fp != host_fingerprint())
    throw PluginVersionError(fmt::format("{}: plugin '{}' was built with [{}], host is [{}]; rebuild it with the "
                                         "same compiler, standard library, Eigen, yaml-cpp and fmt",
                                         path, shown_name, fp, host_fingerprint()));
  if (const std::string why = bad_plugin_name(info.name); !why.empty())
    throw PluginLoadError(fmt::format("{}: not loaded: {} (VARBO_PLUGIN(\"name\", ...) names it)", path, why));
  const std::string name = info.name;
  for (const auto& l : loaded_)
    if (l.name == name) {
      // First wins, and built-in folders are searched first: a third-party library cannot replace a plugin
      // shipped with varbo. Two installs of varbo's own plugins (build tree and prefix) are routine: quiet.
      // Decided from the metadata, so the shadowed library is never loaded.
      if (builtin && l.builtin)
        log_debug("plugin '{}' from {} shadowed by {}", name, path, l.path);
      else
        log_warn("{}: plugin '{}' not loaded: {} plugin of that name is already loaded from {}; rename it",
                 path, name, l.builtin ? "the built-in" : "a", l.path);
      return;
    }
  if (metadata_only_) {
    loaded_.push_back(LoadedLibrary{path, name, info.version, fp, info.description, builtin});
    return;
  }
  const std::clock_t cpu0 = std::clock();  // the --verbose log says what each library costs a short process

  // Built-in plugins were linked with varbo itself (-z defs, same build): their functions are bound lazily,
  // which saves a few ms of symbol lookups per process (`varbo suggest`, docs/studies.md). A third-party library
  // is bound at once, so that a missing symbol is a load error naming it, never a crash mid-study.
  void* handle = dlopen(path.c_str(), (builtin ? RTLD_LAZY : RTLD_NOW) | RTLD_LOCAL);
  if (handle == nullptr) {
    const char* err = dlerror();
    throw PluginLoadError(fmt::format("{}: cannot load: {}", path, err ? err : "unknown dlopen error"));
  }
  // Never dlclose: components and their vtables may be referenced for the life of the process.
  auto reg_fn = reinterpret_cast<varbo_plugin_register_fn>(dlsym(handle, VARBO_PLUGIN_REGISTER_SYMBOL));
  const auto* loaded_meta = static_cast<const varbo_plugin_meta*>(dlsym(handle, VARBO_PLUGIN_META_SYMBOL));
  if (reg_fn == nullptr || loaded_meta == nullptr)
    throw PluginLoadError(fmt::format("{}: not a varbo plugin (no {}/{} entry points; build it with VARBO_PLUGIN "
                                      "and varbo_add_plugin)",
                                      path, VARBO_PLUGIN_META_SYMBOL, VARBO_PLUGIN_REGISTER_SYMBOL));
  // The library dlopen mapped is the one whose metadata was checked (not replaced in between).
  if (std::memcmp(loaded_meta, &info, sizeof info) != 0)
    throw PluginLoadError(fmt::format("{}: the loaded library's metadata differs from the file's (was it replaced "
                                      "while loading?)",
                                      path));
  PluginRegistrar registrar(registry_, name, path);
  char error[1024] = {0};
  const int rc = reg_fn(&registrar, error, sizeof error);
  error[sizeof error - 1] = '\0';
  if (rc != 0) throw PluginLoadError(fmt::format("{}: plugin '{}' failed to register: {}", path, name, error));
  loaded_.push_back(LoadedLibrary{path, name, info.version, fp, info.description, builtin});
  log_debug("plugin '{}' loaded from {}: {:.2f} ms CPU (dlopen, the libraries it needs, registration)", name, path,
            1e3 * static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC);
}

void PluginLoader::skip(const std::string& path, const std::string& reason) {
  skipped_.push_back(SkippedLibrary{path, reason});
  log_warn("skipped plugin library {}", reason);
}

void PluginLoader::load_directory(const std::string& dir) { load_directory(dir, false); }

void PluginLoader::load_directory(const std::string& dir, bool builtin) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return;
  std::vector<std::string> files;
  // error_code overloads throughout: an unreadable folder or an entry that cannot be stat'ed is a warning,
  // never an exception out of every command.
  fs::directory_iterator it(dir, ec), end;
  if (ec) {
    log_warn("plugin folder {}: cannot list it: {}; skipped", dir, ec.message());
    return;
  }
  for (; it != end; it.increment(ec)) {
    if (ec) {
      log_warn("plugin folder {}: stopped listing it: {}", dir, ec.message());
      break;
    }
    const fs::path p = it->path();
    const std::string fname = p.filename().string();
    if (fname.rfind("libvarbo_", 0) == 0 && p.extension() == ".so" && fname != "libvarbo_core.so")
      files.push_back(p.string());
  }
  std::sort(files.begin(), files.end());  // deterministic load order
  for (const auto& f : files) {
    try {
      load_file(f, builtin);
    } catch (const PluginLoadError& e) {
      skip(f, e.what());
    }
  }
}

std::vector<std::string> PluginLoader::env_path() {
  std::vector<std::string> out;
  if (const char* env = std::getenv("VARBO_PLUGIN_PATH")) {
    std::string s = env;
    std::size_t start = 0;
    while (start <= s.size()) {
      const std::size_t end = s.find(':', start);
      const std::string part = s.substr(start, end == std::string::npos ? std::string::npos : end - start);
      if (!part.empty()) out.push_back(part);
      if (end == std::string::npos) break;
      start = end + 1;
    }
  }
  return out;
}

std::vector<std::string> PluginLoader::builtin_path() {
  std::vector<std::string> out;
  Dl_info dl;
  if (dladdr(reinterpret_cast<void*>(&host_fingerprint), &dl) != 0 && dl.dli_fname != nullptr) {
    std::error_code ec;
    const fs::path core = fs::weakly_canonical(fs::path(dl.dli_fname), ec);
    if (!ec) out.push_back((core.parent_path() / "varbo" / "plugins").string());
  }
  if (std::strlen(VARBO_INSTALL_PLUGIN_DIR) > 0) out.push_back(VARBO_INSTALL_PLUGIN_DIR);
  return out;
}

std::vector<std::string> PluginLoader::search_path(const std::vector<std::string>& extra) {
  std::vector<std::string> out = builtin_path();
  out.insert(out.end(), extra.begin(), extra.end());
  for (auto& p : env_path()) out.push_back(std::move(p));
  return out;
}

PluginLoader::~PluginLoader() {
  if (on_demand_) detail::set_on_demand(registry_, nullptr);  // erases by address: safe even if it is gone
}

bool PluginLoader::defer_builtin_folders(const std::vector<std::string>& folders) {
  std::vector<DeferredLibrary> deferred;
  std::set<std::string> seen_dirs, plugins;
  for (const auto& dir : folders) {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) continue;
    std::string canon = fs::weakly_canonical(dir, ec).string();
    if (ec) canon = dir;
    if (!seen_dirs.insert(canon).second) continue;
    const auto index = detail::read_plugin_index(dir);
    if (!index) return false;  // a folder without a current index: load everything, as always
    for (const auto& l : *index) {
      // First wins across folders (load_file): a plugin name seen earlier shadows this library.
      if (!l.plugin.empty() && !plugins.insert(l.plugin).second) continue;
      deferred.push_back(DeferredLibrary{(fs::path(dir) / l.file).string(), l.plugin, l.components, false});
    }
  }
  deferred_ = std::move(deferred);
  return true;
}

void PluginLoader::demand(const std::string& name) {
  std::lock_guard<std::recursive_mutex> lock(demand_mutex_);
  const std::size_t slash = name.find('/');
  for (auto& d : deferred_) {
    if (d.done) continue;
    const bool wanted = name.empty() || (slash != std::string::npos
                                             ? d.plugin == name.substr(0, slash)
                                             : std::find(d.components.begin(), d.components.end(), name) !=
                                                   d.components.end());
    if (!wanted) continue;
    d.done = true;
    try {
      load_file(d.path, true);
    } catch (const PluginLoadError& e) {
      skip(d.path, e.what());
    }
  }
}

void PluginLoader::index_builtin_folder(const std::string& dir) {
  if (detail::read_plugin_index(dir)) return;
  auto files = detail::list_plugin_files(dir);
  if (!files) return;
  const auto all = registry_.all();
  for (auto& f : *files) {
    const std::string path = (fs::path(dir) / f.file).string();
    for (const auto& l : loaded_)
      if (l.path == path) f.plugin = l.name;
    for (const ComponentInfo* c : all)
      if (c->library == path) {
        // A name the index format cannot hold: no index, the folder keeps loading in full.
        if (c->name.find_first_of(" \t\n\r") != std::string::npos || c->name.empty()) return;
        f.components.push_back(c->name);
      }
  }
  detail::write_plugin_index(dir, *files);
}

void PluginLoader::load_default(const std::vector<std::string>& extra) {
  std::set<std::string> seen;
  // A VARBO_PLUGIN_PATH of 1000 stale entries printed 1000 warnings (twice that in `varbo plugins`) on every
  // command: the first few are said, the rest counted (all are still listed as skipped).
  constexpr int kMissingWarnings = 8;
  int missing = 0;
  const bool deferring = on_demand_ && !metadata_only_ && defer_builtin_folders(builtin_path());
  auto load = [&](const std::string& p, bool builtin, const char* origin) {
    std::error_code ec;
    std::string canon = fs::weakly_canonical(p, ec).string();
    if (ec) canon = p;
    if (!seen.insert(canon).second) return;
    const fs::file_status st = fs::status(p, ec);
    if (builtin) {
      if (fs::is_directory(st)) load_directory(p, true);
      return;  // a missing install folder is normal (build tree, relocated prefix)
    }
    if (ec || !fs::exists(st)) {
      const std::string why = ec && ec != std::errc::no_such_file_or_directory ? ec.message() : "does not exist";
      // printable(): a path from the environment may hold a newline or escape sequences.
      if (++missing <= kMissingWarnings) log_warn("plugin path '{}' (from {}): {}; ignored", printable(p), origin, why);
      skipped_.push_back(SkippedLibrary{p, fmt::format("{}: plugin path from {}: {}", p, origin, why)});
    } else if (fs::is_directory(st)) {
      load_directory(p, false);
    } else {
      try {
        load_file(p, false);  // a file named explicitly must load
      } catch (const PluginLoadError& e) {
        // Said where the name came from: an error out of every command for a stray file in VARBO_PLUGIN_PATH
        // named neither the variable nor why a file there must load.
        throw PluginLoadError(fmt::format("{} (a file named in {}: a file there must be a plugin that loads; a "
                                          "folder is scanned)",
                                          e.what(), origin));
      }
    }
  };
  if (!deferring)
    for (const auto& p : builtin_path()) {
      load(p, true, "");
      std::error_code ec;
      if (!metadata_only_ && fs::is_directory(p, ec)) index_builtin_folder(p);
    }
  for (const auto& p : extra) load(p, false, "plugin_path or --load");
  for (const auto& p : env_path()) load(p, false, "VARBO_PLUGIN_PATH");
  if (missing > kMissingWarnings)
    log_warn("{} more plugin paths do not exist; ignored (`varbo plugins` lists them)", missing - kMissingWarnings);
  if (deferring) {
    // Built-in libraries sharing a short name with a third-party component: loaded now, so that the short
    // name keeps meaning the built-in one and the warning below names it.
    std::vector<std::string> names;
    for (const ComponentInfo* c : registry_.all()) names.push_back(c->name);
    for (const auto& n : names) demand(n);
  }
  for (const ComponentInfo* c : shadowed_by_builtin(registry_)) {
    if (std::find(shadowed_.begin(), shadowed_.end(), c) != shadowed_.end()) continue;
    shadowed_.push_back(c);
    const ComponentInfo* b = registry_.try_find(c->kind, c->name);
    log_warn("{}: plugin '{}' registers {} '{}', a built-in name: '{}' keeps meaning the built-in {}; use '{}' "
             "for this one",
             c->library, c->plugin, kind_name(c->kind), c->name, c->name, b ? b->full_name() : c->name,
             c->full_name());
  }
  // Installed last: the checks above list the registry, which on demand would load every library.
  if (deferring) detail::set_on_demand(registry_, [this](const std::string& name) { demand(name); });
}

bool is_builtin(const ComponentInfo& c) {
  // Library paths are built as <folder>/<file> from the very strings builtin_path() returns.
  static const std::vector<std::string> dirs = [] {
    std::vector<std::string> d;
    for (const auto& p : PluginLoader::builtin_path()) d.push_back(fs::path(p).lexically_normal().string());
    return d;
  }();
  const std::string parent = fs::path(c.library).parent_path().lexically_normal().string();
  return !c.library.empty() && std::find(dirs.begin(), dirs.end(), parent) != dirs.end();
}

std::vector<const ComponentInfo*> shadowed_by_builtin(const Registry& registry) {
  std::vector<const ComponentInfo*> out;
  const auto all = registry.all();
  for (const ComponentInfo* c : all) {
    if (is_builtin(*c)) continue;
    for (const ComponentInfo* b : all)
      if (b->kind == c->kind && b->name == c->name && is_builtin(*b)) {
        out.push_back(c);
        break;
      }
  }
  return out;
}

namespace {
struct Defaults {
  Registry registry;
  PluginLoader loader{registry};
};
Defaults& defaults() {
  static Defaults* d = [] {
    auto* x = new Defaults();  // intentionally leaked: plugins are never unloaded
    x->loader.load_default();
    return x;
  }();
  return *d;
}
}  // namespace

Registry& default_registry() { return defaults().registry; }
const PluginLoader& default_loader() { return defaults().loader; }

}  // namespace varbo
