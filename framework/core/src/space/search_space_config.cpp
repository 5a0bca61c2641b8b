// `parameters:` and `constraints:` of a study file.
#include "varbo/search_space_config.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <set>

#include "varbo/csv.hpp"
#include "varbo/errors.hpp"
#include "varbo/numbers.hpp"
#include "varbo/text.hpp"

namespace varbo {

namespace {

const std::vector<std::string> kTypes = {"real", "int", "categorical", "fixed"};

double number_of(const ConfigNode& n, const std::string& what) {
  if (!n.is_scalar()) n.fail("expected " + what);
  // `low: 010` is octal 8 to YAML 1.1 readers (PyYAML, rosparam) and 1e-400 reads as 0: both refused, as the
  // settings are (options.cpp; audit, session 44).
  if (const std::string why = configured_number_problem(n.scalar()); !why.empty())
    n.fail(fmt::format("expected {}, got '{}': {}", what, n.scalar(), why));
  const auto v = parse_decimal(n.scalar());
  if (!v || !std::isfinite(*v)) n.fail(fmt::format("expected {}, got '{}'", what, n.scalar()));
  return *v;
}

bool boolean_of(const ConfigNode& n) {
  if (n.is_scalar()) {
    const std::string s = n.scalar();
    if (s == "true" || s == "yes" || s == "on") return true;
    if (s == "false" || s == "no" || s == "off") return false;
  }
  n.fail("expected true or false");
}

Parameter parse_parameter(const ConfigNode& item) {
  const std::string form = "expected a map such as {name: lr, type: real, low: 1.0e-5, high: 0.1, log: true}";
  if (!item.is_map()) item.fail(form);
  if (!item.has("name")) item.fail("a parameter needs a name; " + form);
  const ConfigNode name = item.child("name");
  if (!name.is_scalar() || name.scalar().empty()) name.fail("expected a parameter name");
  Parameter p;
  p.name = name.scalar();
  for (const char c : p.name)
    if (!(ascii_alnum(c) || c == '_'))
      name.fail(fmt::format("'{}': a parameter name is ASCII letters, digits and '_' (constraints refer to it)",
                            printable(p.name)));
  if (ascii_digit(p.name[0])) name.fail(fmt::format("'{}': a name starts with a letter or '_'", p.name));
  if (!item.has("type")) item.fail(fmt::format("parameter '{}' needs a type: {}", p.name, join(kTypes)));
  const ConfigNode type = item.child("type");
  const std::string t = type.is_scalar() ? type.scalar() : std::string();
  std::vector<std::string> allowed = {"name", "type"};
  if (t == "real" || t == "int") {
    p.type = t == "real" ? ParameterType::Real : ParameterType::Int;
    allowed.insert(allowed.end(), {"low", "high", "log"});
    for (const char* k : {"low", "high"})
      if (!item.has(k)) item.fail(fmt::format("parameter '{}' ({}) needs {}", p.name, t, k));
    p.low = number_of(item.child("low"), t == "int" ? "an integer" : "a finite number");
    p.high = number_of(item.child("high"), t == "int" ? "an integer" : "a finite number");
    // θ holds doubles: beyond 2^53 not every integer is one (a range of ±9.2e18 gave values like 7.14865037247871e+18
    // in trials.csv), and the model's cells of width 1 vanish in rounding. An integer is tested as written: read as
    // a double, 2^53 + 1 became 2^53 and passed (red team, session 34).
    constexpr double kMaxInt = 9007199254740992.0;  // 2^53
    if (p.type == ParameterType::Int)
      for (const char* k : {"low", "high"}) {
        const std::string text = item.child(k).is_scalar() ? item.child(k).scalar() : std::string();
        char* end = nullptr;
        errno = 0;
        const long long written = text.empty() ? 0 : std::strtoll(text.c_str(), &end, 10);
        const bool exact = !text.empty() && end && *end == '\0' && errno == 0;
        constexpr long long kMaxExact = 9007199254740992LL;
        const bool beyond = exact ? (written > kMaxExact || written < -kMaxExact)
                                  : std::abs(k[0] == 'l' ? p.low : p.high) > kMaxInt;
        if (beyond)
          item.child(k).fail(fmt::format("parameter '{}' (int): {} is beyond ±2^53 = {:.0f}, where not every integer "
                                         "is exact in a double; rescale the parameter",
                                         p.name, text, kMaxInt));
      }
    if (item.has("log")) p.log = boolean_of(item.child("log"));
  } else if (t == "categorical") {
    p.type = ParameterType::Categorical;
    allowed.push_back("choices");
    if (!item.has("choices")) item.fail(fmt::format("parameter '{}' (categorical) needs choices: [a, b, ...]", p.name));
    const ConfigNode ch = item.child("choices");
    if (!ch.is_sequence()) ch.fail("expected a list of labels, e.g. [pd, lqr, mpc]");
    for (std::size_t i = 0; i < ch.size(); ++i) {
      const ConfigNode c = ch.item(i);
      if (!c.is_scalar() || c.scalar().empty()) c.fail("expected a non-empty label");
      p.choices.push_back(c.scalar());
    }
  } else if (t == "fixed") {
    p.type = ParameterType::Fixed;
    allowed.push_back("value");
    if (!item.has("value")) item.fail(fmt::format("parameter '{}' (fixed) needs a value", p.name));
    const ConfigNode v = item.child("value");
    if (!v.is_scalar() || v.scalar().empty()) v.fail("expected a number or a label");
    // A plain (unquoted) `value: 010` is a number to varbo and octal 8 to YAML 1.1 readers; quoted it is a label.
    // A quoted value is a label whatever it reads like, as YAML (and ROS's parameter server) reads it: `value: "3.0"`
    // was sent to the command as the number 3 (audit, session 44).
    const bool quoted = v.yaml().Tag() == "!";
    if (!quoted && !configured_number_problem(v.scalar()).empty()) (void)number_of(v, "a number or a label");
    if (const auto d = quoted ? std::nullopt : parse_decimal(v.scalar()); d && std::isfinite(*d)) p.value = *d;
    else p.choices = {v.scalar()};
  } else {
    const std::string near = closest_match(t, kTypes);
    type.fail(fmt::format("unknown parameter type '{}'; expected one of {}{}", t, join(kTypes),
                          near.empty() ? "" : "; did you mean '" + near + "'?"));
  }
  for (const auto& k : item.keys()) {
    if (std::find(allowed.begin(), allowed.end(), k) != allowed.end()) continue;
    const std::string near = closest_match(k, allowed);
    item.child(k).fail(fmt::format("unknown key for a {} parameter; known keys: {}{}", t, join(allowed),
                                   near.empty() ? "" : "; did you mean '" + near + "'?"));
  }
  if (auto problem = check_parameter(p)) {
    const std::string key = item.has(problem->key) ? problem->key : "name";
    item.child(key).fail(fmt::format("parameter '{}': {}", p.name, problem->message));
  }
  return p;
}

}  // namespace

SearchSpace parse_search_space(const ConfigNode& list) {
  if (!list.is_sequence() || list.size() == 0)
    list.fail("expected a non-empty list of parameters, e.g. [{name: lr, type: real, low: 1.0e-5, high: 0.1, log: "
              "true}, {name: solver, type: categorical, choices: [pd, lqr]}]");
  std::vector<Parameter> ps;
  std::set<std::string> seen;
  for (std::size_t i = 0; i < list.size(); ++i) {
    Parameter p = parse_parameter(list.item(i));
    if (!seen.insert(p.name).second)
      list.item(i).child("name").fail(fmt::format("duplicate parameter name '{}'", p.name));
    if (is_trials_table_column(p.name))  // trials.csv would get two columns of that name
      list.item(i).child("name").fail(trials_column_clash(p.name, "parameter"));
    ps.push_back(std::move(p));
  }
  bool free = false;
  for (const auto& p : ps) free = free || p.type != ParameterType::Fixed;
  if (!free) list.fail("every parameter is fixed: there is nothing to optimize");
  return SearchSpace(std::move(ps));
}

void add_constraints(SearchSpace& space, const ConfigNode& list) {
  if (!list.is_sequence() || list.size() == 0)
    list.fail("expected a non-empty list of linear inequalities in user units, e.g. [\"t1 + t2 + t3 <= 5.5\"]");
  for (std::size_t i = 0; i < list.size(); ++i) {
    const ConfigNode c = list.item(i);
    if (!c.is_scalar() || c.scalar().empty()) c.fail("expected a linear inequality such as \"t1 + 2*t2 - t3 <= 5.5\"");
    try {
      space.add_constraint(parse_linear_constraint(c.scalar(), space.parameters()));
    } catch (const ConfigError& e) {
      c.fail(e.what());
    }
  }
  if (!space.finalize())
    list.fail("no admissible point satisfies every constraint (the feasible set is empty, or holds no point with "
              "the integer values required)");
}

}  // namespace varbo
