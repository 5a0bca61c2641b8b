#pragma once
// A YAML node that remembers its file, line, column and key path, so every error can say exactly where.
#include <yaml-cpp/yaml.h>
#include <memory>
#include <string>
#include <vector>

namespace varbo {

class ConfigNode {
 public:
  ConfigNode() = default;
  ConfigNode(YAML::Node node, std::shared_ptr<const std::string> file, std::string path);
  ConfigNode(const ConfigNode&) = default;
  /// Rebinds (YAML::Node::reset): YAML::Node's own operator= writes through to the node it refers to,
  /// which silently overwrote a parent map when a ConfigNode copy of it was assigned a child.
  ConfigNode& operator=(const ConfigNode& other) {
    if (this != &other) {
      node_.reset(other.node_);
      file_ = other.file_;
      path_ = other.path_;
      mark_ = other.mark_;
      has_mark_ = other.has_mark_;
    }
    return *this;
  }

  /// Parses a YAML file; a syntax error becomes a ConfigError naming file:line:col.
  static ConfigNode load_file(const std::string& filename);
  /// Parses YAML text; `name` stands in for the file name in messages.
  static ConfigNode parse(const std::string& text, const std::string& name = "<string>");

  /// The name a study's stored configuration is parsed under: STORE + this suffix.
  static constexpr const char* kStoredSuffix = " (stored configuration)";
  /// Whether this node comes from a study's stored configuration (a study created earlier, maybe by an older
  /// varbo), not from a file the user is about to run: a rule added since must not keep such a study from opening.
  bool from_stored_configuration() const {
    const std::string& f = *file_;
    const std::string suffix = kStoredSuffix;
    return f.size() >= suffix.size() && f.compare(f.size() - suffix.size(), suffix.size(), suffix) == 0;
  }

  const YAML::Node& yaml() const { return node_; }
  const std::string& file() const { return *file_; }
  const std::string& path() const { return path_; }
  /// "file:line:col" of this node (or of its parent's position when the node is absent).
  std::string where() const;
  bool defined() const { return node_.IsDefined() && !node_.IsNull(); }
  bool is_map() const { return node_.IsMap(); }
  bool is_scalar() const { return node_.IsScalar(); }
  bool is_sequence() const { return node_.IsSequence(); }
  bool has(const std::string& key) const;
  /// Child by key; an absent child keeps the parent's position for messages.
  ConfigNode child(const std::string& key) const;
  ConfigNode item(std::size_t i) const;
  std::size_t size() const { return node_.size(); }
  std::vector<std::string> keys() const;
  std::string scalar() const;  ///< the raw text of a scalar

  /// The same value and key path, reported at `place`'s file:line:col: an option's default has no position of its
  /// own ("<default of gp>:1:1" said nothing), so a check that fails on it points at the map that left it out.
  ConfigNode reported_at(const ConfigNode& place) const {
    ConfigNode out = *this;
    out.file_ = place.file_;
    out.mark_ = place.mark_;
    out.has_mark_ = place.has_mark_;
    return out;
  }

  /// Throws ConfigError "file:line:col: key 'a.b.c': message".
  [[noreturn]] void fail(const std::string& message) const;

 private:
  YAML::Node node_;
  std::shared_ptr<const std::string> file_ = std::make_shared<const std::string>("<none>");
  std::string path_;
  YAML::Mark mark_{};
  bool has_mark_ = false;
};

/// "did you mean ...?" helper: the closest candidate by edit distance, if reasonably close.
std::string closest_match(const std::string& word, const std::vector<std::string>& candidates);
std::string join(const std::vector<std::string>& items, const std::string& sep = ", ");

/// A non-empty list of distinct, non-empty names (`what`: "parameter", "cost component"); a ConfigError at the
/// offending item otherwise.
std::vector<std::string> distinct_names(const ConfigNode& list, const std::string& what);

/// A task's `components:` list: distinct_names, none of them a fixed column of the trials table
/// (is_trials_table_column, csv.hpp), which would make a second column of that name.
std::vector<std::string> cost_component_names(const ConfigNode& list);

}  // namespace varbo
