#pragma once
// The one-pass reader of saved states (state.cpp), internal to the core library; exposed for its test against
// YAML::Load (tests/framework/test_state.cpp).
#include <optional>
#include <string>

#include <yaml-cpp/yaml.h>

namespace varbo::detail {
/// The nodes of a state in the one-line flow form StateMap::text() writes, read in one pass; nullopt for any
/// other text (StateMap::parse then uses YAML::Load).
std::optional<YAML::Node> read_flow_state(const std::string& text);
}  // namespace varbo::detail
