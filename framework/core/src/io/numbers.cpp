#include "varbo/numbers.hpp"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <locale>
#include <locale.h>
#include <sstream>

namespace varbo {

namespace {
bool is_digit(char c) { return c >= '0' && c <= '9'; }

bool non_finite_word(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s == "nan" || s == "inf" || s == "infinity";
}

/// [+-]? (digits [. digits?] | . digits) ([eE] [+-]? digits)?
bool decimal_syntax(const std::string& s) {
  std::size_t i = 0;
  const std::size_t n = s.size();
  if (i < n && (s[i] == '+' || s[i] == '-')) ++i;
  std::size_t digits = 0;
  while (i < n && is_digit(s[i])) ++i, ++digits;
  if (i < n && s[i] == '.') {
    ++i;
    while (i < n && is_digit(s[i])) ++i, ++digits;
  }
  if (digits == 0) return false;
  if (i < n && (s[i] == 'e' || s[i] == 'E')) {
    ++i;
    if (i < n && (s[i] == '+' || s[i] == '-')) ++i;
    std::size_t exp = 0;
    while (i < n && is_digit(s[i])) ++i, ++exp;
    if (exp == 0) return false;
  }
  return i == n;
}
}  // namespace

double strtod_c(const char* text, char** end) {
  static const locale_t c_locale = newlocale(LC_NUMERIC_MASK, "C", static_cast<locale_t>(nullptr));
  if (!c_locale) return std::strtod(text, end);  // out of memory at the first call: the process's locale
  return strtod_l(text, end, c_locale);
}

std::string yaml_scalar(double v) {
  if (std::isnan(v)) return ".nan";
  if (std::isinf(v)) return v > 0 ? ".inf" : "-.inf";
  std::ostringstream out;
  out.imbue(std::locale::classic());
  out.precision(std::numeric_limits<double>::max_digits10);
  out << v;
  return out.str();
}

std::optional<double> parse_decimal(const std::string& text) {
  const std::size_t sign = !text.empty() && (text[0] == '+' || text[0] == '-') ? 1 : 0;
  if (!decimal_syntax(text) && !non_finite_word(text.substr(sign))) return std::nullopt;
  errno = 0;
  char* end = nullptr;
  const double v = strtod_c(text.c_str(), &end);
  if (end != text.c_str() + text.size()) return std::nullopt;
  if (errno == ERANGE && std::isinf(v)) return std::nullopt;  // overflow, not a typed "inf"
  // A nonzero number below the smallest double (1e-400) read as 0 in a configuration, a CSV cell or a task's answer,
  // while the command line refused it (audit, session 44): refused everywhere. Subnormals (1e-310) are kept.
  if (errno == ERANGE && v == 0 && decimal_syntax(text) && text.find_first_of("123456789") < text.find_first_of("eE"))
    return std::nullopt;
  return v;
}

bool underflows_to_zero(const std::string& text) {
  if (!decimal_syntax(text)) return false;
  errno = 0;
  char* end = nullptr;
  const double v = strtod_c(text.c_str(), &end);
  return end == text.c_str() + text.size() && errno == ERANGE && v == 0 &&
         text.find_first_of("123456789") < text.find_first_of("eE");
}

bool ambiguous_leading_zero(const std::string& text) {
  const std::size_t d = !text.empty() && (text[0] == '-' || text[0] == '+') ? 1 : 0;
  return text.size() > d + 1 && text[d] == '0' && text.find_first_not_of("0123456789", d) == std::string::npos;
}

std::string configured_number_problem(const std::string& text) {
  if (ambiguous_leading_zero(text))
    return "a leading zero is ambiguous (YAML 1.1 readers such as PyYAML and rosparam read it as an octal number); "
           "write the number without it";
  if (underflows_to_zero(text))
    return "below the smallest number a double holds (about 4.9e-324), it would be read as 0; write 0 if that is "
           "meant";
  return "";
}

}  // namespace varbo
