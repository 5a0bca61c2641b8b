#include "varbo/loader.hpp"

#include <dlfcn.h>
#include <fmt/format.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <set>

#include "varbo/errors.hpp"
#include "varbo/log.hpp"
#include "varbo/plugin.hpp"

#ifndef VARBO_INSTALL_PLUGIN_DIR
#define VARBO_INSTALL_PLUGIN_DIR ""
#endif

namespace fs = std::filesystem;

namespace varbo {

const char* host_fingerprint() { return VARBO_BUILD_FINGERPRINT; }

static bool is_elf(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char magic[4] = {0, 0, 0, 0};
  in.read(magic, 4);
  return in.gcount() == 4 && magic[0] == 0x7f && magic[1] == 'E' && magic[2] == 'L' && magic[3] == 'F';
}

void PluginLoader::load_file(const std::string& path) {
  if (!fs::exists(path)) throw PluginLoadError(fmt::format("{}: plugin library not found", path));
  if (!is_elf(path)) throw PluginLoadError(fmt::format("{}: not a shared library (no ELF header)", path));
  void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (handle == nullptr) {
    const char* err = dlerror();
    throw PluginLoadError(fmt::format("{}: cannot load: {}", path, err ? err : "unknown dlopen error"));
  }
  // Never dlclose: components and their vtables may be referenced for the life of the process.
  auto info_fn = reinterpret_cast<varbo_plugin_info_fn>(dlsym(handle, "varbo_plugin_info_v1"));
  auto reg_fn = reinterpret_cast<varbo_plugin_register_fn>(dlsym(handle, "varbo_plugin_register_v1"));
  if (info_fn == nullptr || reg_fn == nullptr)
    throw PluginLoadError(fmt::format(
        "{}: not a varbo plugin (no varbo_plugin_info_v1/varbo_plugin_register_v1 entry points; "
        "build it with VARBO_PLUGIN and varbo_add_plugin)",
        path));
  const varbo_plugin_info* info = info_fn();
  if (info == nullptr || info->struct_size < sizeof(varbo_plugin_info))
    throw PluginVersionError(fmt::format("{}: plugin info block is missing or too small (older plugin ABI)", path));
  if (info->abi_version != VARBO_ABI_VERSION)
    throw PluginVersionError(fmt::format("{}: plugin '{}' was built for plugin ABI {}, host is ABI {}; rebuild it "
                                         "against this varbo SDK",
                                         path, info->name ? info->name : "?", info->abi_version, VARBO_ABI_VERSION));
  if (info->api_version != VARBO_API_VERSION)
    throw PluginVersionError(fmt::format("{}: plugin '{}' uses API version {}, host is {}", path,
                                         info->name ? info->name : "?", info->api_version, VARBO_API_VERSION));
  const std::string fp = info->fingerprint ? info->fingerprint : "";
  if (fp != host_fingerprint())
    throw PluginVersionError(fmt::format("{}: plugin '{}' was built with [{}], host is [{}]; rebuild it with the "
                                         "same compiler, standard library and Eigen",
                                         path, info->name ? info->name : "?", fp, host_fingerprint()));
  const std::string name = info->name ? info->name : "";
  for (const auto& l : loaded_)
    if (l.name == name) {
      log_debug("plugin '{}' from {} shadowed by {}", name, path, l.path);
      return;
    }
  registry_.set_origin(name, path);
  char error[1024] = {0};
  const int rc = reg_fn(&registry_, error, sizeof error);
  registry_.set_origin("", "");
  if (rc != 0) throw PluginLoadError(fmt::format("{}: plugin '{}' failed to register: {}", path, name, error));
  loaded_.push_back(LoadedLibrary{path, name, info->version ? info->version : "", fp,
                                  info->description ? info->description : ""});
}

void PluginLoader::load_directory(const std::string& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return;
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string fname = e.path().filename().string();
    if (fname.rfind("libvarbo_", 0) == 0 && e.path().extension() == ".so" && fname != "libvarbo_core.so")
      files.push_back(e.path().string());
  }
  std::sort(files.begin(), files.end());  // deterministic load order
  for (const auto& f : files) {
    try {
      load_file(f);
    } catch (const PluginLoadError& e) {
      skipped_.push_back(SkippedLibrary{f, e.what()});
      log_warn("skipped plugin library {}", e.what());
    }
  }
}

std::vector<std::string> PluginLoader::search_path(const std::vector<std::string>& extra) {
  std::vector<std::string> out(extra.begin(), extra.end());
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
  Dl_info dl;
  if (dladdr(reinterpret_cast<void*>(&host_fingerprint), &dl) != 0 && dl.dli_fname != nullptr) {
    const fs::path core = fs::weakly_canonical(fs::path(dl.dli_fname));
    out.push_back((core.parent_path() / "varbo" / "plugins").string());
  }
  if (std::strlen(VARBO_INSTALL_PLUGIN_DIR) > 0) out.push_back(VARBO_INSTALL_PLUGIN_DIR);
  return out;
}

void PluginLoader::load_default(const std::vector<std::string>& extra) {
  std::set<std::string> seen;
  for (const auto& p : search_path(extra)) {
    std::error_code ec;
    const std::string canon = fs::weakly_canonical(p, ec).string();
    if (!seen.insert(canon).second) continue;
    if (fs::is_regular_file(p, ec)) {
      load_file(p);  // a file named explicitly must load
    } else {
      load_directory(p);
    }
  }
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
