#pragma once
// Strict parsing of numbers given on the command line: "1.5x" or "" is an error, never a silent 1.5 or 0.
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <cstdint>
#include <string>
#include <utility>

#include "varbo/errors.hpp"
#include "varbo/numbers.hpp"

namespace varbo::cli {
/// A finite or non-finite decimal number; InputError naming `what` when malformed.
double parse_number(const std::string& text, const std::string& what);
/// A trial id: a non-negative integer.
std::int64_t parse_id(const std::string& text);
/// An integer flag read as text: CLI11 saturated 99999999999999999999 to 2^63 − 1 and took `--seed -1` as "not
/// given"; here either is an error naming the flag and the range, as the same key in the file gets.
inline long long integer_flag(const std::string& text, const char* flag, long long lo) {
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || errno == ERANGE || v < lo)
    throw InputError(fmt::format("{}: expected an integer in [{}, {}], got '{}'", flag, lo,
                                 std::numeric_limits<long long>::max(), text));
  return v;
}

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
