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

/// The plugin folders named by a study or a run folder that this process may load code from: owned by this user
/// or by root, and not writable by every user. Reading a study a colleague sent, or one in a folder another user
/// can write, ran whatever libvarbo_*.so its stored paths named (red team, session 30) — as git refuses a
/// repository another user owns. Each folder left out is warned about once, with how to trust it on purpose
/// (VARBO_PLUGIN_PATH, which is never filtered). `what` names where the paths come from.
std::vector<std::string> trusted_plugin_folders(const std::vector<std::string>& paths, const std::string& what);

}  // namespace study_detail
}  // namespace varbo
