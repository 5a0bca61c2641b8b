#pragma once
// Text encodings of a trial's vectors and components, shared by the store backends: JSON with 17 significant
// digits, so that every double comes back bit-identical.
#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>
#include <string>

#include "varbo/errors.hpp"
#include "varbo/task.hpp"

namespace varbo::store_codec {

inline std::string vec_text(const Vec& v) {
  nlohmann::json a = nlohmann::json::array();
  for (Index i = 0; i < v.size(); ++i) a.push_back(v[i]);  // dumped with 17 significant digits: exact
  return a.dump();
}

/// The fast path of text_vec: "[v1,v2,...]" as vec_text writes it, read with std::from_chars, which rounds
/// correctly as the JSON parser does (the same doubles). A process opening a study reads every finished trial, and
/// a JSON document per vector was ~4 % of a `varbo suggest` at N = 400. False for anything else (the JSON parser
/// then decides).
inline bool read_number_array(const std::string& s, Vec& out) {
  if (s.size() < 2 || s.front() != '[' || s.back() != ']') return false;
  const char* p = s.data() + 1;
  const char* const end = s.data() + s.size() - 1;
  std::vector<double> values;
  while (p != end) {
    double v = 0;
    const auto [next, ec] = std::from_chars(p, end, v);
    if (ec != std::errc() || next == p || !std::isfinite(v)) return false;
    values.push_back(v);
    p = next;
    if (p != end && *p++ != ',') return false;
    if (p == end && s[s.size() - 2] == ',') return false;  // "[1,]"
  }
  out = Eigen::Map<const Vec>(values.data(), static_cast<Index>(values.size()));
  return true;
}

/// The store's `schema_version` meta entry: a whole decimal number, or 0 (corrupt) for anything else — stoi read
/// "2abc" as 2 and opened a store whose meta table had been damaged.
inline int schema_version_of(const std::optional<std::string>& text) {
  if (!text || text->empty()) return 0;
  int v = 0;
  const char* const end = text->data() + text->size();
  const auto [next, ec] = std::from_chars(text->data(), end, v);
  return ec == std::errc() && next == end ? v : 0;
}

inline Vec text_vec(const std::string& s, const std::string& where) {
  if (Vec v; read_number_array(s, v)) return v;
  nlohmann::json a = nlohmann::json::parse(s, nullptr, false);
  if (!a.is_array()) throw InputError(fmt::format("{}: corrupt vector '{}'", where, s));
  Vec v(static_cast<Index>(a.size()));
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (!a[i].is_number()) throw InputError(fmt::format("{}: corrupt vector '{}'", where, s));
    v[static_cast<Index>(i)] = a[i].get<double>();
  }
  return v;
}

inline std::string components_text(const Components& c) {
  nlohmann::json o = nlohmann::json::array();  // an ordered list of [name, value] pairs keeps the task's order
  for (const auto& [name, value] : c) o.push_back({name, std::isfinite(value) ? nlohmann::json(value) : nlohmann::json()});
  return o.dump();
}

inline Components text_components(const std::string& s) {
  Components c;
  if (s == "[]") return c;  // most tasks: no components
  nlohmann::json o = nlohmann::json::parse(s, nullptr, false);
  if (!o.is_array()) return c;
  for (const auto& p : o)
    if (p.is_array() && p.size() == 2 && p[0].is_string())
      c.emplace_back(p[0].get<std::string>(), p[1].is_number() ? p[1].get<double>() : std::nan(""));
  return c;
}

}  // namespace varbo::store_codec
