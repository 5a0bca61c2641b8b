#include "stored_plugin_paths.hpp"

#include <filesystem>
#include <sstream>
#include "varbo/store.hpp"

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
  return out;
}

}  // namespace varbo::study_detail
