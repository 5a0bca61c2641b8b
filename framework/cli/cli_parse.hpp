#pragma once
// Strict parsing of numbers given on the command line: "1.5x" or "" is an error, never a silent 1.5 or 0.
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>

#include "varbo/numbers.hpp"

namespace varbo::cli {
/// A finite or non-finite decimal number; InputError naming `what` when malformed.
double parse_number(const std::string& text, const std::string& what);
/// A trial id: a non-negative integer.
std::int64_t parse_id(const std::string& text);
/// CLI11 check for numeric options (--kappa, --epsilon): decimal notation only, as for COST ("0x10" is refused),
/// and finite (`--kappa nan` printed "no selection" and exited 1).
inline CLI::Validator decimal_number() {
  return CLI::Validator(
      [](std::string& text) {
        const auto v = parse_decimal(text);
        return v && std::isfinite(*v)
                   ? std::string()
                   : "expected a finite decimal number such as 0.25 or -1.5e-3, got '" + text + "'";
      },
      "DECIMAL");
}
/// "name=value".
std::pair<std::string, double> parse_component(const std::string& text);
}  // namespace varbo::cli
