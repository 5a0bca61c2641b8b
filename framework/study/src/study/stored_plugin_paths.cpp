#include "stored_plugin_paths.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <fmt/format.h>

#include <filesystem>
#include <mutex>
#include <set>
#include <sstream>

#include "varbo/log.hpp"
#include "varbo/store.hpp"
#include "varbo/text.hpp"

namespace fs = std::filesystem;

namespace varbo::study_detail {

namespace {

std::vector<std::string> lines_of(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string l; std::getline(ss, l);) out.push_back(l);
  return out;
}

/// The folder of a study file; empty for a database address (a study there has no folder to move with).
fs::path folder_of(const std::string& store_address) {
  if (is_database_url(store_address)) return {};
  std::error_code ec;
  const fs::path abs = fs::absolute(store_address, ec);
  return ec ? fs::path{} : abs.parent_path();
}

}  // namespace

std::vector<std::pair<std::string, std::string>> plugin_path_entries(const std::vector<std::string>& paths,
                                                                     const std::string& store_address) {
  const fs::path folder = folder_of(store_address);
  std::string absolute, relative;
  for (const auto& p : paths) {
    std::error_code ec;
    const fs::path abs = fs::absolute(p, ec).lexically_normal();
    absolute += abs.string() + "\n";
    // Relative to the study file's folder, so that the run folder and the plugins it was run with can move
    // together (a project copied to the lab's machine); an empty line when there is no such form.
    const fs::path rel = folder.empty() ? fs::path{} : abs.lexically_relative(folder);
    relative += rel.string() + "\n";
  }
  std::vector<std::pair<std::string, std::string>> out = {{store_key::kPluginPaths, absolute}};
  if (!folder.empty()) out.emplace_back(kPluginPathsRelative, relative);
  return out;
}

std::vector<std::string> stored_plugin_paths(const StudyStore& store, const std::string& store_address) {
  std::vector<std::string> out;
  const auto absolute = lines_of(store.meta(store_key::kPluginPaths).value_or(""));
  const fs::path folder = folder_of(store_address);
  // Studies stored before the relative form existed have absolute paths only.
  const auto relative =
      folder.empty() ? std::vector<std::string>{} : lines_of(store.meta(kPluginPathsRelative).value_or(""));
  for (std::size_t i = 0; i < absolute.size(); ++i) {
    if (absolute[i].empty()) continue;
    std::string chosen = absolute[i];
    if (i < relative.size() && !relative[i].empty()) {
      // Where the study is now comes first: a copied project loads its own copy of the plugins, not the
      // original's (which may have been rebuilt since, or be gone).
      const fs::path here = (folder / relative[i]).lexically_normal();
      std::error_code ec;
      if (fs::exists(here, ec)) chosen = here.string();
    }
    out.push_back(chosen);
  }
  return trusted_plugin_folders(out, "the study " + store.location());
}

std::vector<std::string> trusted_plugin_folders(const std::vector<std::string>& paths, const std::string& what) {
  static std::mutex mutex;
  static std::set<std::string> warned;
  std::vector<std::string> out;
  for (const std::string& p : paths) {
    struct stat st {};
    // A folder that is not there is kept: the loader says so, naming it. Symbolic links are followed (the folder
    // that is read is the one judged).
    if (::stat(p.c_str(), &st) != 0) {
      out.push_back(p);
      continue;
    }
    const bool owner_ok = st.st_uid == ::geteuid() || st.st_uid == 0;
    const bool world_writable = (st.st_mode & S_IWOTH) != 0 && (st.st_mode & S_ISVTX) == 0;
    if (owner_ok && !world_writable) {
      out.push_back(p);
      continue;
    }
    std::lock_guard<std::mutex> lock(mutex);
    if (warned.insert(p).second)
      log_warn("{} names the plugin folder {}, {}: its plugins are not loaded (a study or run folder from "
               "elsewhere must not run code by being read). If you trust them: VARBO_PLUGIN_PATH={}",
               printable(what), printable(p),
               owner_ok ? std::string("which every user can write")
                        : fmt::format("which belongs to another user (uid {})", static_cast<long>(st.st_uid)),
               printable(p));
  }
  return out;
}

}  // namespace varbo::study_detail
