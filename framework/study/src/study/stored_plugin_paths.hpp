#pragma once
// The plugin paths a study was created with (its configuration's `plugin_path`), as stored with the study and as
// found again when it is opened: a project moved or copied with its run folder and plugins keeps working.
#include <string>
#include <utility>
#include <vector>

namespace varbo {
class StudyStore;

namespace study_detail {

/// Meta key: the plugin paths relative to a study file's folder, line for line with store_key::kPluginPaths (a study
/// file only; studies created before 2026-12-04 have none).
inline constexpr const char* kPluginPathsRelative = "plugin_paths_relative";

/// Meta entries for a new store at `store_address` holding the study whose plugin paths are `paths`: the absolute
/// paths (store_key::kPluginPaths) and, for a study file, each path relative to the file's folder
/// (kPluginPathsRelative, one line per path, in the same order).
std::vector<std::pair<std::string, std::string>> plugin_path_entries(const std::vector<std::string>& paths,
                                                                     const std::string& store_address);

/// The plugin paths to load for the study in `store` at `store_address`: for a study file, a path's stored
/// relative form where it exists beside the file as it is now (the project was moved or copied), else the
/// absolute path stored at creation. A path found under neither is kept as stored (the loader warns, naming it).
std::vector<std::string> stored_plugin_paths(const StudyStore& store, const std::string& store_address);

}  // namespace study_detail
}  // namespace varbo
