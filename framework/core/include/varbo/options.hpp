#pragma once
// Declared options of a component: the single source for validation, defaults, `varbo plugins --describe`
// and the run's config.resolved.yaml.
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>
#include "varbo/config.hpp"

namespace varbo {

enum class Kind { Surrogate, Acquisition, Region, Sampler, Optimizer, Task, Algorithm, Kernel };
std::string kind_name(Kind kind);
Kind kind_from_name(const std::string& name);  // throws ConfigError

/// Path: a file name; a relative one given in a configuration file is read relative to that file's folder and
/// resolved to an absolute path (config.resolved.yaml and the stored study hold that), so a run resumed from
/// another folder finds the same file.
enum class OptionType { Bool, Int, Real, String, Choice, RealList, Component, Node, Path };
std::string type_name(OptionType type);

struct OptionSpec {
  std::string name;
  OptionType type = OptionType::Real;
  std::string default_yaml;  ///< YAML text of the default; empty with required=false means "unset"
  std::string description;
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool min_open = false;
  bool max_open = false;
  bool required = false;
  std::vector<std::string> choices;  ///< for Choice
  Kind component_kind = Kind::Surrogate;  ///< for Component

  OptionSpec& at_least(double v) { min = v; min_open = false; return *this; }
  OptionSpec& above(double v) { min = v; min_open = true; return *this; }
  OptionSpec& at_most(double v) { max = v; max_open = false; return *this; }
  OptionSpec& below(double v) { max = v; max_open = true; return *this; }
  OptionSpec& must() { required = true; return *this; }
  /// "a real number in (0, inf)" and the like, for messages and --describe.
  std::string expected() const;
};

/// Builders: opt::real("xi", 0.01, "exploration ...").at_least(0). Plugins bind options to the fields of a
/// settings struct instead (varbo/option_set.hpp), so the default is written once.
namespace opt {
OptionSpec boolean(std::string name, bool def, std::string description);
OptionSpec integer(std::string name, long def, std::string description);
OptionSpec real(std::string name, double def, std::string description);
OptionSpec string(std::string name, std::string def, std::string description);
OptionSpec path(std::string name, std::string description);  ///< OptionType::Path, no default
OptionSpec choice(std::string name, std::string def, std::vector<std::string> choices, std::string description);
OptionSpec reals(std::string name, std::string def_yaml, std::string description);
OptionSpec component(std::string name, Kind kind, std::string def_yaml, std::string description);
/// A YAML value the owner validates itself. With a map as default, a given map is resolved over it key by key
/// (Options::resolved() names every key; the given node, for validation and messages, is Options::node()).
OptionSpec node(std::string name, std::string def_yaml, std::string description);
}  // namespace opt

struct ComponentInfo;
struct ResolvedComponent;

/// Validated option values of one component. Accessors throw std::logic_error for undeclared names
/// (a programming error, not user input).
class Options {
 public:
  Options() = default;
  bool boolean(const std::string& name) const;
  long integer(const std::string& name) const;
  double real(const std::string& name) const;
  std::string str(const std::string& name) const;
  std::vector<double> reals(const std::string& name) const;
  const ResolvedComponent& component(const std::string& name) const;
  ConfigNode node(const std::string& name) const;  ///< for OptionType::Node and positions in messages
  bool is_set(const std::string& name) const;      ///< has a value (given or defaulted)
  bool given(const std::string& name) const;       ///< given explicitly by the user
  bool declared(const std::string& name) const;    ///< among the specs these options were validated with
  const ConfigNode& source() const { return source_; }
  /// The options with every default filled in, as YAML.
  YAML::Node resolved() const;

 private:
  friend Options validate_options(const ConfigNode&, const std::vector<OptionSpec>&, const std::string&,
                                  const class Registry*, const std::vector<std::string>&);
  const YAML::Node& value(const std::string& name) const;
  ConfigNode source_;
  std::vector<std::string> order_;
  std::map<std::string, YAML::Node> values_;
  std::map<std::string, ConfigNode> nodes_;
  std::map<std::string, std::shared_ptr<ResolvedComponent>> components_;
  std::map<std::string, bool> given_;
};

/// Validates the keys of a map node against `specs`. Unknown keys, wrong types and out-of-range values
/// throw ConfigError with file:line:col, the key path and the expected form. `owner` names the component
/// in messages. Component options are resolved recursively through `registry` (may be null when none).
/// `ignored_keys` are keys handled by the caller (e.g. "type").
/// Why an option's declared default is not a value of its own spec (not YAML, out of range, not a choice), or
/// empty. The registry refuses such a declaration when the plugin loads: a default that fails its own check was
/// reported at the user's configuration, which never named the option (red team, session 26).
std::string option_default_problem(const OptionSpec& spec);

Options validate_options(const ConfigNode& node, const std::vector<OptionSpec>& specs, const std::string& owner,
                         const class Registry* registry, const std::vector<std::string>& ignored_keys = {"type"});

}  // namespace varbo
