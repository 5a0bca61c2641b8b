#pragma once
// A component given on the command line: inline YAML ("gp", "{type: vhgp, restarts: 16}") or a YAML file
// (a component map, or a study file whose `algorithm.<key>` or `<key>` names it).
#include <filesystem>
#include <string>

#include "varbo/config.hpp"

namespace varbo::cli {

inline ConfigNode component_arg(const std::string& text, const std::string& key, const std::string& flag) {
  if (std::filesystem::is_regular_file(text)) {
    ConfigNode root = ConfigNode::load_file(text);
    if (root.is_map() && root.has("algorithm") && root.child("algorithm").has(key))
      return root.child("algorithm").child(key);
    if (root.is_map() && root.has(key)) return root.child(key);
    return root;
  }
  return ConfigNode::parse(text, flag);
}

}  // namespace varbo::cli
