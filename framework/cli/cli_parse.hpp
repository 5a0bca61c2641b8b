#pragma once
// Strict parsing of numbers given on the command line: "1.5x" or "" is an error, never a silent 1.5 or 0.
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <cstdint>
#include <filesystem>
#include <system_error>
#include <string>
#include <utility>
#include <vector>

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

/// CLI11 check for whole-number options (--threads, --grid, --port, ...): decimal digits only, in [lo, hi]. CLI11's
/// own checks took 0x10 as 16, saturated 1e23 to 2^63 − 1 and said "not in range 0.000000 to 1797693…" (309 digits).
inline CLI::Validator integer_in(long long lo, long long hi) {
  return CLI::Validator(
      [lo, hi](std::string& text) {
        const std::string expected = fmt::format("expected a whole number in [{}, {}], got '{}'", lo, hi, text);
        const std::size_t start = !text.empty() && text[0] == '-' ? 1 : 0;
        if (text.size() == start || text.find_first_not_of("0123456789", start) != std::string::npos) return expected;
        errno = 0;
        const long long v = std::strtoll(text.c_str(), nullptr, 10);
        return errno == ERANGE || v < lo || v > hi ? expected : std::string();
      },
      fmt::format("INT in [{}, {}]", lo, hi));
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
/// After decimal_number(): a positive one. CLI11's PositiveNumber said "Value 0 not in range 0.000000 to
/// 1797693…" (audit, session 47).
inline CLI::Validator positive_decimal(const std::string& what) {
  return CLI::Validator(
      [what](std::string& text) {
        const auto v = parse_decimal(text);
        return v && *v > 0 ? std::string() : "expected a finite number > 0 (" + what + "), got '" + text + "'";
      },
      "POSITIVE");
}
/// CLI11 check for a run folder argument (select, plot, rescore): CLI11's ExistingDirectory said "run: Directory is
/// actually a file: DIR/trials.csv" for a file of the folder (audit, session 44); this names what is expected and,
/// for a file, the folder it lies in.
inline CLI::Validator run_folder() {
  return CLI::Validator(
      [](std::string& text) {
        std::error_code ec;
        const std::filesystem::path path(text);
        const auto status = std::filesystem::status(path, ec);
        if (std::filesystem::is_directory(status)) return std::string();
        const std::string expected = "expected a run folder written by `varbo run -o DIR` (config.resolved.yaml, trials.csv)";
        if (!std::filesystem::exists(status)) return fmt::format("'{}' does not exist; {}", text, expected);
        const std::string parent = path.parent_path().empty() ? std::string(".") : path.parent_path().string();
        return fmt::format("'{}' is a file, not a folder; {}: its folder, '{}'?", text, expected, parent);
      },
      "RUN_FOLDER");
}

/// The items of a list option given comma-separated and/or repeated ("--kappa 2,0 --kappa -2"). An empty item
/// ("1,,2", a trailing comma, "") is an error naming the flag: CLI11's own `delimiter` dropped it silently, so a
/// mistyped list ran with fewer values than written.
inline std::vector<std::string> list_items(const std::vector<std::string>& given, const std::string& flag,
                                           const std::string& example) {
  std::vector<std::string> out;
  for (const auto& text : given) {
    std::size_t start = 0;
    while (true) {
      const std::size_t comma = text.find(',', start);
      std::string item = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
      // "a, b" names b, as the CSV header "a, b" does (spaces around a cell are not part of it).
      const auto b = item.find_first_not_of(" \t");
      item = b == std::string::npos ? std::string() : item.substr(b, item.find_last_not_of(" \t") - b + 1);
      if (item.empty())
        throw InputError(fmt::format("{}: an empty item in '{}'; expected a comma-separated list such as {}", flag,
                                     text, example));
      out.push_back(item);
      if (comma == std::string::npos) break;
      start = comma + 1;
    }
  }
  return out;
}
/// list_items of finite decimal numbers (as decimal_number() checks one).
inline std::vector<double> decimal_items(const std::vector<std::string>& given, const std::string& flag,
                                         const std::string& example) {
  std::vector<double> out;
  for (const auto& item : list_items(given, flag, example)) {
    const auto v = parse_decimal(item);
    if (!v || !std::isfinite(*v))
      throw InputError(fmt::format("{}: expected a finite decimal number such as 0.25 or -1.5e-3, got '{}'", flag, item));
    out.push_back(*v);
  }
  return out;
}
/// "name=value".
std::pair<std::string, double> parse_component(const std::string& text);
/// An option given an empty value (`--timeout ''`, `--worker=`) was read as "not given": the study's 600 s timeout
/// ran where the user meant to set one. Throws InputError naming the first such option of a parsed command.
void refuse_empty_values(const CLI::App& app);
}  // namespace varbo::cli
