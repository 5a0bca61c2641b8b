// Params: the typed view of one point of a search space.
#include "varbo/params.hpp"

#include <fmt/format.h>

#include <cmath>
#include <stdexcept>

namespace varbo {

std::string parameter_type_name(ParameterType t) {
  switch (t) {
    case ParameterType::Real: return "real";
    case ParameterType::Int: return "int";
    case ParameterType::Categorical: return "categorical";
    case ParameterType::Fixed: return "fixed";
  }
  return "?";
}

bool Params::has(const std::string& name) const {
  for (const auto& n : names)
    if (n == name) return true;
  return false;
}

const ParamValue& Params::at(const std::string& name) const {
  for (std::size_t i = 0; i < names.size() && i < values.size(); ++i)
    if (names[i] == name) return values[i];
  throw std::out_of_range("no parameter named '" + name + "'");
}

double Params::real(const std::string& name) const {
  const ParamValue& v = at(name);
  if (v.is_label()) throw std::invalid_argument("parameter '" + name + "' is a label ('" + v.label + "'), not a number");
  return v.number;
}

long Params::integer(const std::string& name) const {
  const double v = real(name);
  if (v != std::round(v)) throw std::invalid_argument(fmt::format("parameter '{}' = {} is not an integer", name, v));
  return static_cast<long>(v);
}

const std::string& Params::label(const std::string& name) const {
  const ParamValue& v = at(name);
  if (!v.is_label()) throw std::invalid_argument(fmt::format("parameter '{}' is a number ({}), not a label", name, v.number));
  return v.label;
}

namespace {
std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (const char c : s) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\t': out += "\\t"; break;
      case '\r': out += "\\r"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) out += fmt::format("\\u{:04x}", static_cast<unsigned>(c));
        else out += c;
    }
  }
  return out + "\"";
}
}  // namespace

std::string Params::to_json() const {
  std::string out = "{";
  for (std::size_t i = 0; i < names.size() && i < values.size(); ++i) {
    const ParamValue& v = values[i];
    out += (i ? ", " : "") + json_string(names[i]) + ": ";
    if (v.is_label()) out += json_string(v.label);
    else if (v.type == ParameterType::Int) out += fmt::format("{}", static_cast<long>(v.number));
    else out += fmt::format("{:.17g}", v.number);
  }
  return out + "}";
}

}  // namespace varbo
