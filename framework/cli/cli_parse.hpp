#pragma once
// Strict parsing of numbers given on the command line: "1.5x" or "" is an error, never a silent 1.5 or 0.
#include <cstdint>
#include <string>
#include <utility>

namespace varbo::cli {
/// A finite or non-finite decimal number; InputError naming `what` when malformed.
double parse_number(const std::string& text, const std::string& what);
/// A trial id: a non-negative integer.
std::int64_t parse_id(const std::string& text);
/// "name=value".
std::pair<std::string, double> parse_component(const std::string& text);
}  // namespace varbo::cli
