#pragma once
// A component given on the command line: inline YAML ("gp", "{type: vhgp, restarts: 16}") or a YAML file
// (a component map, or a study file whose `algorithm.<key>` or `<key>` names it).
#include <fmt/format.h>

#include <filesystem>
#include <string>

#include "varbo/config.hpp"
#include "varbo/errors.hpp"

namespace varbo::cli {

inline ConfigNode component_arg(const std::string& text, const std::string& key, const std::string& flag) {
  const std::string expected = fmt::format(
      "{} takes a YAML file (a {} map, or a study file whose algorithm has a '{}:'), a built-in name (e.g. {}) or "
      "inline YAML such as '{}'",
      flag, key, key, key == "surrogate" ? "gp, vhgp" : "multistart",
      key == "surrogate" ? "{type: gp, kernel: se_ard}" : "{type: multistart, candidates: 500}");
  std::error_code ec;
  // Anything that exists is a file to read: load_file() refuses a folder, FIFO or device by name (parsing its
  // path as a component name would say "unknown surrogate 'runs/'").
  if (std::filesystem::exists(text, ec)) {
    ConfigNode root = ConfigNode::load_file(text);
    if (root.has("algorithm") && root.child("algorithm").has(key)) return root.child("algorithm").child(key);
    if (root.has(key)) return root.child(key);
    if (root.has("task") || root.has("algorithm"))
      root.fail(fmt::format("this study file names no {0} (no 'algorithm.{0}:' key); {1}", key, expected));
    return root;
  }
  // A path that does not exist: say so rather than reading the path as a component name.
  const auto ends_with = [&](const char* s) {
    const std::string e(s);
    return text.size() >= e.size() && text.compare(text.size() - e.size(), e.size(), e) == 0;
  };
  const bool inline_yaml = text.find_first_of("{}[]:\n") != std::string::npos;
  if (!inline_yaml && (text.find('/') != std::string::npos || ends_with(".yaml") || ends_with(".yml") ||
                       ends_with(".json")))
    throw ConfigError(fmt::format("{}: cannot open configuration file (no such file); {}", text, expected));
  return ConfigNode::parse(text, flag);
}

}  // namespace varbo::cli
