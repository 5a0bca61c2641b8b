#pragma once
// Which library of a built-in plugin folder provides which component names, so that a process opening a study
// loads only the libraries its configuration needs (`varbo suggest`: docs/studies.md). The index is a small
// text file in the folder, written by a process that loaded the whole folder, and trusted only while every
// library in the folder has the size and modification time it records, and the host the same fingerprint:
// anything else (a rebuilt, added or removed plugin) makes the folder load in full again, as without an index.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace varbo::detail {

struct IndexedLibrary {
  std::string file;                  ///< file name inside the folder
  std::uintmax_t size = 0;
  std::int64_t mtime_ns = 0;
  std::string plugin;                ///< "" for a library that was skipped (failed its checks) when indexed
  std::vector<std::string> components;  ///< short names of the components it registered
};

inline constexpr const char* kPluginIndexFile = "varbo_plugins.index";

/// The libvarbo_*.so files of `dir` with their sizes and times (plugin and components left empty), sorted by
/// name; nullopt when the folder cannot be listed.
std::optional<std::vector<IndexedLibrary>> list_plugin_files(const std::string& dir);

/// The index of `dir` when it is current (see above); nullopt when missing, unreadable, malformed or stale.
std::optional<std::vector<IndexedLibrary>> read_plugin_index(const std::string& dir);

/// Writes the index of `dir` atomically (a temporary file renamed over it). Failures (a read-only install
/// folder) are ignored: the folder then simply keeps loading in full.
void write_plugin_index(const std::string& dir, const std::vector<IndexedLibrary>& libraries);

}  // namespace varbo::detail
