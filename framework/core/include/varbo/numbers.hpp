#pragma once
// One strict reading of a number typed by a user (command line, external command answers, CSV files,
// configuration reals): decimal notation only. strtod alone also takes "0x10" (16), "1e999" (inf) and leading
// blanks, which turn typos into silently wrong costs.
#include <optional>
#include <string>
#include <type_traits>

namespace varbo {

/// The value of `text` when the whole text is a decimal number: optional sign, digits with an optional
/// point, an optional exponent (e.g. 12, -0.5, .25, 3., 1.5e-3), or one of nan / inf / infinity (any case,
/// with a sign) so that the caller can reject non-finite values with its own message. Nothing else: no
/// hexadecimal, no blanks, no overflow (1e999), no underflow to 0 (1e-400: below the smallest double); a subnormal
/// (1e-310) reads as the nearest representable value. underflows_to_zero says which of the last two it was.
std::optional<double> parse_decimal(const std::string& text);
/// Whether `text` is a decimal number whose value is nonzero but below the smallest double (it would read as 0).
bool underflows_to_zero(const std::string& text);
/// Whether `text` is a whole number written with a leading zero (`010`, `-07`): YAML 1.1 readers (PyYAML, rosparam)
/// read it as octal (or, `08`, as a string), so a configuration that means 10 by it is ambiguous.
bool ambiguous_leading_zero(const std::string& text);
/// Why a number written as `text` in a configuration is refused although it reads: a leading zero (ambiguous) or an
/// underflow to 0; "" when neither. One wording for the settings (options.cpp) and the parameters' bounds and values.
std::string configured_number_problem(const std::string& text);

/// std::strtod as in the "C" locale, whatever the process's LC_NUMERIC: a host that calls setlocale (a Qt, GTK or
/// ROS GUI, Python's locale.setlocale) with a decimal-comma locale made strtod stop at the '.', so "0.01" read as 0
/// and every plugin default, configuration real and saved state was refused or cut (red team, session 28).
/// Every number varbo reads goes through this or parse_decimal.
double strtod_c(const char* text, char** end);

/// `v` as yaml-cpp writes a number (`YAML::Node(v)`: max_digits10 significant digits, .nan, .inf, -.inf), but
/// always in the "C" locale. yaml-cpp formats through a std::stringstream, which follows the host's global C++
/// locale: a program that called std::locale::global(std::locale("")) under LANG=de_DE.UTF-8 or en_US.UTF-8 stored
/// `xi: 0,01` and `candidates: 2,000`, a study no other process could open (red team, session 31). Every number
/// varbo puts into a YAML node or a file goes through this, std::to_string (integers) or fmt (never the `L` form).
std::string yaml_scalar(double v);
template <class T>
  requires(std::is_integral_v<T> && !std::is_same_v<T, bool>)
std::string yaml_scalar(T v) {
  return std::to_string(v);  // locale-independent, unlike a stream
}

}  // namespace varbo
