#include "varbo/options.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cerrno>
#include <limits>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <cstdlib>
#include <stdexcept>

#include "kind_text.hpp"
#include "varbo/errors.hpp"
#include "varbo/numbers.hpp"
#include "varbo/option_set.hpp"
#include "varbo/registry.hpp"
#include "varbo/text.hpp"

namespace varbo {

std::string kind_name(Kind kind) {
  switch (kind) {
    case Kind::Surrogate: return "surrogate";
    case Kind::Acquisition: return "acquisition";
    case Kind::Region: return "region";
    case Kind::Sampler: return "sampler";
    case Kind::Optimizer: return "optimizer";
    case Kind::Task: return "task";
    case Kind::Algorithm: return "algorithm";
    case Kind::Kernel: return "kernel";
  }
  return "?";
}

std::string kind_with_article(Kind kind) {
  const std::string name = kind_name(kind);
  return (std::string("aeiou").find(name[0]) != std::string::npos ? "an " : "a ") + name;
}

Kind kind_from_name(const std::string& name) {
  for (Kind k : {Kind::Surrogate, Kind::Acquisition, Kind::Region, Kind::Sampler, Kind::Optimizer, Kind::Task,
                 Kind::Algorithm, Kind::Kernel})
    if (kind_name(k) == name) return k;
  throw ConfigError("unknown component kind '" + name +
                    "'; known: surrogate, acquisition, region, sampler, optimizer, task, algorithm, kernel");
}

std::string type_name(OptionType type) {
  switch (type) {
    case OptionType::Bool: return "bool";
    case OptionType::Int: return "integer";
    case OptionType::Real: return "real";
    case OptionType::String: return "string";
    case OptionType::Choice: return "choice";
    case OptionType::RealList: return "list of reals";
    case OptionType::Component: return "component";
    case OptionType::Node: return "yaml";  // a map or a list (`phases:` is a list)
    case OptionType::Path: return "path";
  }
  return "?";
}

static std::string fmt_bound(double v) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return fmt::format("{}", v);
}

std::string OptionSpec::expected() const {
  auto range = [&]() -> std::string {
    if (std::isinf(min) && std::isinf(max)) return "";
    // An infinite bound is open: no option accepts inf or nan (`timeout: .inf` read "expected ... in (0, inf]").
    const bool lo_open = min_open || std::isinf(min), hi_open = max_open || std::isinf(max);
    return fmt::format(" in {}{}, {}{}", lo_open ? "(" : "[", fmt_bound(min), fmt_bound(max), hi_open ? ")" : "]");
  };
  switch (type) {
    case OptionType::Bool: return "true or false";
    case OptionType::Int: return "an integer" + range();
    case OptionType::Real: return "a real number" + range();
    case OptionType::String: return "a string";
    case OptionType::Choice: return "one of: " + join(choices, ", ");
    case OptionType::RealList: return "a list of real numbers, e.g. [0.1, 0.2]";
    case OptionType::Component:
      return kind_with_article(component_kind) + " name or a map with 'type:' and its options";
    case OptionType::Node: return "a YAML value";
    case OptionType::Path: return "a file path (a relative one is read from the configuration file's folder)";
  }
  return "?";
}

namespace opt {
static OptionSpec make(std::string name, OptionType t, std::string def, std::string description) {
  OptionSpec s;
  s.name = std::move(name);
  s.type = t;
  s.default_yaml = std::move(def);
  s.description = std::move(description);
  return s;
}
OptionSpec boolean(std::string name, bool def, std::string d) {
  return make(std::move(name), OptionType::Bool, def ? "true" : "false", std::move(d));
}
OptionSpec integer(std::string name, long def, std::string d) {
  return make(std::move(name), OptionType::Int, std::to_string(def), std::move(d));
}
OptionSpec real(std::string name, double def, std::string d) {
  return make(std::move(name), OptionType::Real, fmt::format("{}", def), std::move(d));
}
OptionSpec string(std::string name, std::string def, std::string d) {
  return make(std::move(name), OptionType::String, def.empty() ? "" : "\"" + def + "\"", std::move(d));
}
OptionSpec path(std::string name, std::string d) { return make(std::move(name), OptionType::Path, "", std::move(d)); }
OptionSpec choice(std::string name, std::string def, std::vector<std::string> choices, std::string d) {
  OptionSpec s = make(std::move(name), OptionType::Choice, std::move(def), std::move(d));
  s.choices = std::move(choices);
  return s;
}
OptionSpec reals(std::string name, std::string def_yaml, std::string d) {
  return make(std::move(name), OptionType::RealList, std::move(def_yaml), std::move(d));
}
OptionSpec component(std::string name, Kind kind, std::string def_yaml, std::string d) {
  OptionSpec s = make(std::move(name), OptionType::Component, std::move(def_yaml), std::move(d));
  s.component_kind = kind;
  return s;
}
OptionSpec node(std::string name, std::string def_yaml, std::string d) {
  return make(std::move(name), OptionType::Node, std::move(def_yaml), std::move(d));
}
}  // namespace opt

namespace detail {
std::string reals_yaml(const std::vector<double>& values) {
  if (values.empty()) return "";
  return fmt::format("[{}]", fmt::join(values, ", "));
}
}  // namespace detail

static bool parse_real(const std::string& text, double& out) {
  // YAML spellings of infinity.
  if (text == ".inf" || text == ".Inf" || text == "+.inf") { out = INFINITY; return true; }
  if (text == "-.inf" || text == "-.Inf") { out = -INFINITY; return true; }
  const std::optional<double> v = parse_decimal(text);  // decimal only: no 0x10, no 1e999
  if (!v) return false;
  out = *v;
  return true;
}

static bool parse_int(const std::string& text, long& out) {
  // strtol skips leading white space: `budget: " 3"` ran 3 where `noise_std: ' 0.1'` was refused (red team,
  // session 24). One rule for every number: no white space.
  if (text.empty() || ascii_space(text.front())) return false;
  char* end = nullptr;
  errno = 0;
  out = std::strtol(text.c_str(), &end, 10);
  return *end == '\0' && errno == 0;
}

static bool in_range(const OptionSpec& s, double v) {
  if (std::isnan(v)) return false;
  if (s.min_open ? !(v > s.min) : !(v >= s.min)) return false;
  if (s.max_open ? !(v < s.max) : !(v <= s.max)) return false;
  return true;
}

static std::string shown(const ConfigNode& n) {
  if (n.is_scalar()) return fmt::format("'{}'", safe_text(n.scalar(), 40));
  if (n.is_sequence()) return "a list";
  if (n.is_map()) return "a map";
  return "nothing";
}

/// The key `name` of the map `node` itself, for errors about a value that has no position of its own: yaml-cpp
/// marks an empty value (`budget:` then a newline) at the next token, a line below.
static ConfigNode key_node(const ConfigNode& node, const std::string& name) {
  for (const auto& kv : node.yaml())
    if (kv.first.IsScalar() && kv.first.Scalar() == name)
      return ConfigNode(kv.first, std::make_shared<const std::string>(node.file()),
                        node.path().empty() ? name : node.path() + "." + name);
  return node.child(name);
}

/// `010`: YAML 1.1 readers (PyYAML, rosparam) read it as octal 8 (and `08` as a string), varbo as 10 — ambiguous,
/// so refused, for integer and real settings alike (`timeout: 010` ran 10 s; audit, session 44); `0.5`, `0`, `-0` and
/// `010.5` (a float in YAML 1.1 too) are fine. And 1e-400: nonzero, below the smallest double, read as 0.
static void refuse_ambiguous_number(const ConfigNode& n, const std::string& expected) {
  if (const std::string why = configured_number_problem(n.scalar()); !why.empty())
    n.fail(fmt::format("expected {}, got {}: {}", expected, shown(n), why));
}

// Checks one value; returns the normalized YAML value.
static YAML::Node check_value(const OptionSpec& s, const ConfigNode& n) {
  auto bad = [&]() { n.fail(fmt::format("expected {}, got {}", s.expected(), shown(n))); };
  // An explicit YAML tag that contradicts the setting's type: `budget: !!float 3` ran 3 where `budget: 3.0` is
  // refused (red team, session 24). `!!str` is quoting spelled as a tag and is read like a quoted value
  // (config/a15_budget_tag_str_ok), so it is not refused here.
  const std::string tag = n.yaml().IsScalar() ? n.yaml().Tag() : std::string();
  auto tagged = [&](const char* name) { return tag == std::string("tag:yaml.org,2002:") + name; };
  auto bad_tag = [&]() {
    n.fail(fmt::format("expected {}, got {} tagged !!{}", s.expected(), shown(n), tag.substr(tag.rfind(':') + 1)));
  };
  switch (s.type) {
    case OptionType::Bool: if (tagged("int") || tagged("float")) bad_tag(); break;
    case OptionType::Int: if (tagged("float") || tagged("bool")) bad_tag(); break;
    case OptionType::Real: if (tagged("bool")) bad_tag(); break;
    default: break;
  }
  switch (s.type) {
    case OptionType::Bool: {
      if (!n.is_scalar()) bad();
      bool b;
      if (!YAML::convert<bool>::decode(n.yaml(), b)) bad();
      return YAML::Node(b);
    }
    case OptionType::Int: {
      long v;
      if (!n.is_scalar()) bad();
      // `budget: 010` ran 10 trials, where YAML 1.1 (PyYAML, rosparam) reads octal 8 (red team, session 34).
      refuse_ambiguous_number(n, s.expected());
      if (!parse_int(n.scalar(), v)) {
        // A whole number past what a long holds: "expected an integer in [0, inf), got 18446744073709551616"
        // read as a contradiction (red team, session 23); say the limit.
        if (errno == ERANGE)
          n.fail(fmt::format("expected {}, got {}: beyond the largest integer a setting holds ({})", s.expected(),
                             shown(n), std::numeric_limits<long>::max()));
        bad();
      }
      if (!in_range(s, static_cast<double>(v))) bad();
      return YAML::Node(yaml_scalar(v));
    }
    case OptionType::Real: {
      double v;
      // Non-finite values (.inf, .nan) are never a setting: an infinite noise_std made every trial fail.
      if (n.is_scalar()) refuse_ambiguous_number(n, s.expected());
      if (!n.is_scalar() || !parse_real(n.scalar(), v) || !std::isfinite(v) || !in_range(s, v)) bad();
      return YAML::Node(yaml_scalar(v));
    }
    case OptionType::String: {
      if (!n.is_scalar()) bad();
      return YAML::Node(n.scalar());
    }
    case OptionType::Path: {
      if (!n.is_scalar()) bad();
      // Relative to the configuration file that holds it, not to the folder varbo runs in: `history: h.csv` beside
      // the config worked only when run from there, and a --resume from elsewhere could not find it (audit,
      // session 45). Stored absolute, so the stored study names the same file. A configuration that is no file
      // (a stored study, a string) keeps the path as written: relative to the working folder, as before.
      const std::filesystem::path given(n.scalar());
      std::error_code ec;
      if (given.empty() || given.is_absolute() || !std::filesystem::is_regular_file(n.file(), ec))
        return YAML::Node(n.scalar());
      const std::filesystem::path base = std::filesystem::absolute(n.file(), ec).parent_path();
      return YAML::Node(ec ? n.scalar() : (base / given).lexically_normal().string());
    }
    case OptionType::Choice: {
      if (!n.is_scalar()) bad();
      const std::string v = n.scalar();
      for (const auto& c : s.choices)
        if (c == v) return YAML::Node(v);
      const std::string near = closest_match(v, s.choices);
      n.fail(fmt::format("expected {}, got '{}'{}", s.expected(), safe_text(v, 40), near.empty() ? "" : "; did you mean '" + near + "'?"));
    }
    case OptionType::RealList: {
      if (!n.is_sequence()) bad();
      YAML::Node out(YAML::NodeType::Sequence);
      for (std::size_t i = 0; i < n.size(); ++i) {
        ConfigNode it = n.item(i);
        double v;
        if (it.is_scalar()) refuse_ambiguous_number(it, "a finite real number");
        if (!it.is_scalar() || !parse_real(it.scalar(), v) || !std::isfinite(v))
          it.fail(fmt::format("expected a finite real number, got {}", shown(it)));
        if (!in_range(s, v)) it.fail(fmt::format("value {} out of range: expected {}", v, s.expected()));
        out.push_back(yaml_scalar(v));
      }
      return out;
    }
    case OptionType::Component:
    case OptionType::Node:
      return n.yaml();
  }
  return {};
}

/// A map option given in part (`failure_model: {min_probability: 0.3}`) resolves to its default map with the
/// given keys replaced, in the default's order (keys the default lacks follow): the resolved configuration then
/// names every setting, so a resumed study keeps the settings it was created with when a later version changes a
/// default. The plugin still validates the given map itself (Options::node keeps the user's node and positions).
static YAML::Node merged_over_default(const YAML::Node& def, const YAML::Node& given) {
  if (!def.IsMap()) return given;
  for (const auto& kv : given)  // a key that is not a name: left to the owner's validation, which reports it
    if (!kv.first.IsScalar()) return given;
  YAML::Node out(YAML::NodeType::Map);
  for (const auto& kv : def) {
    const std::string key = kv.first.as<std::string>();
    out[key] = given[key] ? YAML::Clone(given[key]) : YAML::Clone(kv.second);
  }
  for (const auto& kv : given) {
    const std::string key = kv.first.as<std::string>();
    if (!def[key]) out[key] = YAML::Clone(kv.second);
  }
  return out;
}

std::string option_default_problem(const OptionSpec& s) {
  if (s.default_yaml.empty()) return {};
  YAML::Node value;
  try {
    value = YAML::Load(s.default_yaml);
  } catch (const YAML::Exception& e) {
    return fmt::format("its default '{}' is not YAML ({})", printable(s.default_yaml), e.msg);
  }
  // A component is resolved against the registry when a configuration uses it; a node is its owner's to check.
  if (s.type == OptionType::Component || s.type == OptionType::Node) return {};
  try {
    (void)check_value(s, ConfigNode(value, std::make_shared<const std::string>("<default>"), s.name));
  } catch (const ConfigError&) {
    return fmt::format("its default {} is not {}", printable(s.default_yaml), s.expected());
  }
  return {};
}

Options validate_options(const ConfigNode& node, const std::vector<OptionSpec>& specs, const std::string& owner,
                         const Registry* registry, const std::vector<std::string>& ignored_keys) {
  Options o;
  o.source_ = node;
  if (node.defined() && !node.is_map() && !node.is_scalar())
    node.fail(fmt::format("expected a map of options for {}", owner));
  std::vector<std::string> known;
  for (const auto& s : specs) known.push_back(s.name);
  if (node.is_map()) {
    for (const auto& kv : node.yaml()) {
      const std::string key = kv.first.as<std::string>();
      bool ignored = false;
      for (const auto& k : ignored_keys) ignored = ignored || (k == key);
      if (ignored) continue;
      bool found = false;
      for (const auto& s : specs) found = found || (s.name == key);
      if (!found) {
        const std::string near = closest_match(key, known);
        // Point at the key itself, not at its value.
        const std::string shown_key = safe_text(key, 40);  // a 1 MB key is not repeated whole
        ConfigNode key_node(kv.first, std::make_shared<const std::string>(node.file()),
                            node.path().empty() ? shown_key : node.path() + "." + shown_key);
        key_node.fail(fmt::format("unknown key for {}; known keys: {}{}", owner,
                                         known.empty() ? "(none)" : join(known),
                                         near.empty() ? "" : "; did you mean '" + near + "'?"));
      }
    }
  }
  for (const auto& s : specs) {
    o.order_.push_back(s.name);
    ConfigNode given = node.is_map() ? node.child(s.name) : ConfigNode();
    // `key:` with no value (or `~`, `null`) is most often a value left out by mistake (`budget:` ran the default
    // 30 trials): say so rather than use the default silently.
    if (node.is_map() && node.has(s.name) && !given.defined())
      key_node(node, s.name).fail(fmt::format("no value given (empty, ~ or null); expected {}{}", s.expected(),
                             s.default_yaml.empty() ? std::string("; leave the key out if it is not needed")
                                                    : "; leave the key out for the default " + s.default_yaml));
    const bool is_given = given.defined();
    o.given_[s.name] = is_given;
    ConfigNode use;
    if (is_given) {
      use = given;
    } else if (!s.default_yaml.empty()) {
      use = ConfigNode(YAML::Load(s.default_yaml),
                       std::make_shared<const std::string>("<default of " + owner + ">"),
                       node.path().empty() ? s.name : node.path() + "." + s.name);
      // A check of two options (min_signal_std < max_signal_std) may fail on the default one: point at the
      // user's map that left it out, not at "<default of gp>:1:1".
      if (node.defined()) use = use.reported_at(node);
    } else if (s.required) {
      (node.is_map() ? node.child(s.name) : node)
          .fail(fmt::format("missing required key for {}: expected {}", owner, s.expected()));
    } else {
      continue;
    }
    o.nodes_[s.name] = use;
    // One assignment to a fresh entry: assigning a YAML::Node to one that already refers to the user's node would
    // overwrite that node in place (yaml-cpp's reference semantics), and with it the positions of its messages.
    o.values_.emplace(s.name, s.type == OptionType::Node && use.is_map() && !s.default_yaml.empty()
                                  ? merged_over_default(YAML::Load(s.default_yaml), use.yaml())
                                  : check_value(s, use));
    if (s.type == OptionType::Component) {
      if (registry == nullptr) throw std::logic_error("validate_options: component option without registry");
      o.components_[s.name] = std::make_shared<ResolvedComponent>(registry->resolve(s.component_kind, use));
    }
  }
  return o;
}

const YAML::Node& Options::value(const std::string& name) const {
  auto it = values_.find(name);
  if (it == values_.end()) throw std::logic_error("option '" + name + "' was not declared or has no value");
  return it->second;
}

bool Options::boolean(const std::string& name) const { return value(name).as<bool>(); }
long Options::integer(const std::string& name) const {
  // As yaml_real below: yaml-cpp's stream would follow the host's global C++ locale.
  const YAML::Node& n = value(name);
  long v = 0;
  if (n.IsScalar() && parse_int(n.Scalar(), v)) return v;
  return n.as<long>();
}
// Read by varbo's own number rule, not yaml-cpp's stream: that one follows the global C++ locale, where a host's
// std::locale::global(de_DE) made '.' a thousands separator.
static double yaml_real(const YAML::Node& n) {
  double v = 0;
  if (n.IsScalar() && parse_real(n.Scalar(), v)) return v;
  return n.as<double>();
}

double Options::real(const std::string& name) const { return yaml_real(value(name)); }
std::string Options::str(const std::string& name) const { return value(name).as<std::string>(); }
std::vector<double> Options::reals(const std::string& name) const {
  const YAML::Node& n = value(name);
  if (!n.IsSequence()) return n.as<std::vector<double>>();
  std::vector<double> out;
  for (const auto& e : n) out.push_back(yaml_real(e));
  return out;
}

const ResolvedComponent& Options::component(const std::string& name) const {
  auto it = components_.find(name);
  if (it == components_.end()) throw std::logic_error("option '" + name + "' is not a component");
  return *it->second;
}

ConfigNode Options::node(const std::string& name) const {
  auto it = nodes_.find(name);
  if (it != nodes_.end()) return it->second;
  return source_.child(name);
}

bool Options::is_set(const std::string& name) const { return values_.count(name) > 0; }
bool Options::declared(const std::string& name) const {
  for (const auto& n : order_)
    if (n == name) return true;
  return false;
}

bool Options::given(const std::string& name) const {
  auto it = given_.find(name);
  return it != given_.end() && it->second;
}

YAML::Node Options::resolved() const {
  YAML::Node out(YAML::NodeType::Map);
  for (const auto& name : order_) {
    auto c = components_.find(name);
    if (c != components_.end()) {
      out[name] = c->second->resolved();
      continue;
    }
    auto v = values_.find(name);
    if (v != values_.end()) out[name] = v->second;
  }
  return out;
}

}  // namespace varbo
