#pragma once
// Helpers for tests that run whole studies in-process.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "varbo/csv.hpp"
#include "varbo/study.hpp"

namespace varbo::test {

/// The whole content of a file ("" if it cannot be read).
inline std::string slurp(const std::string& file) {
  std::ifstream in(file);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// A fresh, empty folder under the system temp dir, one set per build tree (the hash of the test program's
/// folder) and user, so that test suites of several checkouts running at once never share a folder, nor two users
/// running one build's tests (each removed the other's folders; red team, session 31).
inline std::string temp_folder(const std::string& name) {
  std::error_code ec;
  const std::size_t tree = std::hash<std::string>{}(std::filesystem::canonical("/proc/self/exe", ec).parent_path().string());
  const auto p = std::filesystem::temp_directory_path() /
                 ("varbo_test_" + std::to_string(::getuid()) + "_" + std::to_string(tree % 100000)) / name;
  std::filesystem::remove_all(p);
  std::filesystem::create_directories(p);
  return p.string();
}

/// trials.csv as rows of strings (header first).
inline std::vector<std::vector<std::string>> read_rows(const std::string& file) { return read_csv_cells(file); }

inline int column_of(const std::vector<std::string>& header, const std::string& name) {
  for (std::size_t i = 0; i < header.size(); ++i)
    if (header[i] == name) return static_cast<int>(i);
  return -1;
}

/// Runs a study given as YAML text against `registry`.
inline RunSummary run_yaml(const std::string& yaml, const Registry& registry, RunOverrides ov = {}) {
  ov.progress = false;
  if (!ov.resume) ov.overwrite = true;  // tests rerun studies into their scratch folders
  StudyConfig s = parse_study(ConfigNode::parse(yaml, "<test study>"), registry);
  return run_study(s, registry, ov);
}

}  // namespace varbo::test
