#include "cli_parse.hpp"

#include <fmt/format.h>

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>

#include "varbo/errors.hpp"
#include "varbo/numbers.hpp"
#include "varbo/text.hpp"

namespace varbo::cli {

double parse_number(const std::string& text, const std::string& what) {
  const std::optional<double> v = parse_decimal(text);
  // Out of a double's range is said as such: 1e400 was "malformed", and 1e-400 was stored as 0 without a word
  // (red team, session 34).
  errno = 0;
  char* end = nullptr;
  const double read = strtod_c(text.c_str(), &end);
  const bool whole = !text.empty() && end == text.c_str() + text.size();
  if (!v && whole && errno == ERANGE && std::isinf(read))
    throw InputError(fmt::format("{}: '{}' is beyond the largest number a double holds (about ±1.8e308); nothing "
                                 "written",
                                 what, printable(text)));
  if (underflows_to_zero(text))
    throw InputError(fmt::format("{}: '{}' is below the smallest number a double holds (about 4.9e-324) and would "
                                 "be stored as 0; write 0 if that is meant; nothing written",
                                 what, printable(text)));
  if (!v)
    throw InputError(fmt::format("{}: malformed number '{}' (expected a decimal number such as 0.25 or -1.5e-3); "
                                 "nothing written",
                                 what, printable(text)));  // a CR from a CRLF file is shown, not obeyed
  return *v;
}

std::int64_t parse_id(const std::string& text) {
  const char* s = text.c_str();
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(s, &end, 10);
  // strtoll skips leading blanks: ' 1' and a tab before the id were taken (audit, session 44); digits only (a
  // '+' sign aside, accepted since session 11).
  const std::size_t first = !text.empty() && text[0] == '+' ? 1 : 0;
  if (text.size() <= first || !std::isdigit(static_cast<unsigned char>(text[first])) || end == s || *end != '\0' ||
      errno == ERANGE || v < 0)
    throw InputError(fmt::format("ID: malformed trial id '{}' (expected a non-negative integer as printed by "
                                 "`varbo suggest`); nothing written",
                                 printable(text)));
  return v;
}

std::pair<std::string, double> parse_component(const std::string& text) {
  const auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0)
    throw InputError(fmt::format("--component: expected name=value, got '{}'; nothing written", printable(text)));
  const std::string name = text.substr(0, eq);
  return {name, parse_number(text.substr(eq + 1), fmt::format("--component {}", name))};
}

void refuse_empty_values(const CLI::App& app) {
  for (const CLI::Option* opt : app.get_options()) {
    // Not given, a flag (no value), or a positional argument (the command's own check names what it expects).
    if (opt->count() == 0 || opt->get_type_size_max() == 0 || !opt->nonpositional()) continue;
    for (const std::string& value : opt->results())
      if (value.empty())
        throw InputError(fmt::format("{}: an empty value; give a value (`varbo {} --help`) or leave the option out",
                                     opt->get_name(), app.get_name()));
  }
  for (const CLI::App* sub : app.get_subcommands()) refuse_empty_values(*sub);
}

}  // namespace varbo::cli
