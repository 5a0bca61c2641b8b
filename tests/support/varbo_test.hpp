#pragma once
// Helpers for the doctest suites.
#include <doctest/doctest.h>

#include <string>

#include "varbo/loader.hpp"
#include "varbo/registry.hpp"

namespace varbo::test {
/// The registry with every plugin of this build tree loaded.
inline Registry& registry() { return default_registry(); }
inline std::string source_path(const std::string& rel) { return std::string(VARBO_SOURCE_DIR) + "/" + rel; }
inline std::string binary_path(const std::string& rel) { return std::string(VARBO_BINARY_DIR) + "/" + rel; }
}  // namespace varbo::test
