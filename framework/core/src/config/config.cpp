#include "varbo/config.hpp"

#include <fmt/format.h>
#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/eventhandler.h>

#include <algorithm>
#include <fstream>
#include <optional>
#include <set>
#include <sstream>

#include "../io/utf8.hpp"
#include "varbo/csv.hpp"
#include "varbo/errors.hpp"
#include "varbo/regular_file.hpp"
#include "varbo/text.hpp"

namespace varbo {

ConfigNode::ConfigNode(YAML::Node node, std::shared_ptr<const std::string> file, std::string path)
    : node_(std::move(node)), file_(std::move(file)), path_(std::move(path)) {
  if (node_.IsDefined()) {
    mark_ = node_.Mark();
    has_mark_ = mark_.line >= 0;
  }
}

namespace {

std::string at(const std::string& name, const YAML::Mark& m) {
  if (m.line < 0) return name;
  return fmt::format("{}:{}:{}", name, m.line + 1, m.column + 1);
}

/// Plain, quoted and the YAML core-schema tags; any other (`!foo`, `!!binary`) would be silently dropped.
bool known_tag(const std::string& tag) {
  static const char* core = "tag:yaml.org,2002:";
  if (tag.empty() || tag == "?" || tag == "!") return true;
  if (tag.rfind(core, 0) != 0) return false;
  const std::string t = tag.substr(std::string(core).size());
  return t == "str" || t == "int" || t == "float" || t == "bool" || t == "null" || t == "map" || t == "seq";
}

/// Counts the values a walk of the tree visits. Aliases (*a) make the tree a graph whose expansion can be
/// exponential in the file's size ("billion laughs": 10 lines of nested aliases, 10^10 values), and every walk of
/// the configuration (checks, options, the study's identity) expands it; a configuration holds hundreds.
struct WalkBudget {
  static constexpr std::size_t kMaxValues = 1'000'000;
  std::size_t visited = 0;
  void visit(const std::string& name, const YAML::Node& n) {
    if (++visited > kMaxValues)
      throw ConfigError(fmt::format("{}: the configuration expands to more than {} values through its aliases "
                                    "(*name); a configuration holds far fewer",
                                    at(name, n.Mark()), kMaxValues));
  }
};

/// YAML text is Unicode; a Latin-1 'é' (0xE9) from an old editor would reach names, trials.csv and the store as a
/// stray byte. yaml-cpp passes such bytes through, so every key and value is checked (after yaml-cpp has decoded a
/// UTF-16 file, which is fine).
void check_utf8(const YAML::Node& n, const std::string& name) {
  // A NUL is valid UTF-8 but ends a C string: `output: "out\0x"` made the folder `out`, `command: "echo 1\0…"` ran
  // `echo 1`, a name or label came back cut from trials.csv. No setting holds one ("\0" or "\u0000" in quotes).
  if (const std::size_t nul = n.Scalar().find('\0'); nul != std::string::npos)
    throw ConfigError(fmt::format("{}: a NUL byte (\\0) at offset {} of this value; no setting holds one",
                                  at(name, n.Mark()), nul));
  const std::size_t at_byte = invalid_utf8_at(n.Scalar());
  if (at_byte == std::string::npos) return;
  throw ConfigError(fmt::format("{}: byte 0x{:02X} (at offset {} of this value) is not UTF-8; save the file as UTF-8",
                                at(name, n.Mark()), static_cast<unsigned char>(n.Scalar()[at_byte]), at_byte));
}

/// A core-schema tag must describe its node: yaml-cpp keeps the tag but not its meaning, so `task: !!null branin`
/// ran Branin where PyYAML reads null, and `algorithm: !!seq {type: random}` ran the map (red team, session 34).
/// Scalar tags (!!int, !!bool, ...) on a scalar are checked against the option's type where it is read.
void check_tag_matches(const YAML::Node& n, const std::string& name) {
  static const std::string core = "tag:yaml.org,2002:";
  const std::string& tag = n.Tag();
  if (tag.rfind(core, 0) != 0) return;
  const std::string t = tag.substr(core.size());
  const char* kind = n.IsMap() ? "a map" : n.IsSequence() ? "a list" : "a value";
  const bool scalar_tag = t == "str" || t == "int" || t == "float" || t == "bool" || t == "null";
  const std::string& v = n.IsScalar() ? n.Scalar() : std::string();
  const bool fits = t == "map"        ? n.IsMap()
                    : t == "seq"      ? n.IsSequence()
                    : t == "null"     ? (n.IsNull() || (n.IsScalar() && (v.empty() || v == "~" || v == "null" ||
                                                                         v == "Null" || v == "NULL")))
                    : scalar_tag      ? (n.IsScalar() || n.IsNull())
                                      : true;
  if (!fits)
    throw ConfigError(fmt::format("{}: the tag !!{} does not describe this node ({}{}); a configuration uses plain "
                                  "values: remove the tag",
                                  at(name, n.Mark()), t, kind, n.IsScalar() ? " '" + v + "'" : std::string()));
}

/// What yaml-cpp accepts but a configuration must not hold: a key given twice (the first would win silently),
/// a key that is not a plain scalar, an unknown tag, absurd nesting or alias expansion.
void check_structure(const YAML::Node& n, const std::string& name, int depth, WalkBudget& budget) {
  if (depth > 64) throw ConfigError(fmt::format("{}: nested more than 64 levels deep", at(name, n.Mark())));
  budget.visit(name, n);
  if (!known_tag(n.Tag()))
    throw ConfigError(fmt::format("{}: unknown YAML tag '{}' (a configuration uses plain values, no tags)",
                                  at(name, n.Mark()), n.Tag()));
  check_tag_matches(n, name);
  if (n.IsScalar()) check_utf8(n, name);
  if (n.IsMap()) {
    std::vector<std::pair<std::string, YAML::Mark>> seen;
    for (const auto& kv : n) {
      if (!kv.first.IsScalar())
        throw ConfigError(fmt::format("{}: a key must be a plain name, not a list or a map", at(name, kv.first.Mark())));
      check_utf8(kv.first, name);
      if (!known_tag(kv.first.Tag()))
        throw ConfigError(fmt::format("{}: unknown YAML tag '{}' on key '{}'", at(name, kv.first.Mark()),
                                      kv.first.Tag(), kv.first.Scalar()));
      const std::string key = kv.first.Scalar();
      for (const auto& [k, mark] : seen)
        if (k == key)
          throw ConfigError(fmt::format("{}: duplicate key '{}' (first given at line {}); each key may appear once "
                                        "in a map",
                                        at(name, kv.first.Mark()), key, mark.line + 1));
      seen.emplace_back(key, kv.first.Mark());
      check_structure(kv.second, name, depth + 1, budget);
    }
  } else if (n.IsSequence()) {
    for (const auto& item : n) check_structure(item, name, depth + 1, budget);
  }
}

/// A plain `<<` key (YAML 1.1 merge key, https://yaml.org/type/merge.html); `"<<"` quoted is an ordinary key.
bool is_merge_key(const YAML::Node& key) {
  return key.IsScalar() && key.Scalar() == "<<" && (key.Tag() == "?" || key.Tag() == "tag:yaml.org,2002:merge");
}

/// Resolves YAML merge keys, which yaml-cpp 0.7 (Debian 12) reads as a plain key '<<': `<<: *defaults` or
/// `<<: [*a, *b]` adds the merged maps' keys that the map does not give itself, earlier maps first — the shared
/// defaults of ROS-style parameter files. Merged values keep their own positions (the anchor's lines) for errors.
/// In place: a map reached twice through an alias is resolved once, to the same result.
void resolve_merge_keys(YAML::Node n, const std::string& name, int depth, WalkBudget& budget) {
  if (depth > 64) return;  // check_structure() reports the nesting
  budget.visit(name, n);
  if (n.IsSequence()) {
    for (YAML::Node item : n) resolve_merge_keys(item, name, depth + 1, budget);
    return;
  }
  if (!n.IsMap()) return;
  std::vector<YAML::Node> merged;
  std::optional<YAML::Node> merge_key;
  std::vector<std::string> own;
  for (auto kv : n) {
    if (is_merge_key(kv.first)) {
      if (merge_key)
        throw ConfigError(fmt::format("{}: duplicate merge key '<<' (first given at line {}); merge several maps "
                                      "with one list, <<: [*a, *b]",
                                      at(name, kv.first.Mark()), merge_key->Mark().line + 1));
      merge_key = kv.first;
      const YAML::Node value = kv.second;
      if (value.IsMap()) {
        merged.push_back(value);
      } else if (value.IsSequence() && std::all_of(value.begin(), value.end(), [](const YAML::Node& m) {
                   return m.IsMap();
                 })) {
        for (const YAML::Node& m : value) merged.push_back(m);
      } else {
        const std::string got = value.IsScalar() ? "'" + value.Scalar() + "'" : "a list holding a non-map";
        throw ConfigError(fmt::format("{}: the merge key '<<' takes a map or a list of maps (e.g. <<: *defaults), "
                                      "got {}",
                                      at(name, value.Mark()), got));
      }
    } else {
      if (kv.first.IsScalar()) own.push_back(kv.first.Scalar());
      resolve_merge_keys(kv.second, name, depth + 1, budget);
    }
  }
  if (!merge_key) return;
  for (YAML::Node m : merged) resolve_merge_keys(m, name, depth + 1, budget);
  n.remove(*merge_key);
  for (const YAML::Node& m : merged)
    for (const auto& kv : m) {
      if (!kv.first.IsScalar()) continue;  // check_structure() reports a non-scalar key where the map is used
      const std::string key = kv.first.Scalar();
      if (std::find(own.begin(), own.end(), key) != own.end()) continue;
      own.push_back(key);
      n.force_insert(kv.first, kv.second);
    }
}

}  // namespace

namespace {
/// Counts the documents the parser starts and where the second one starts; builds nothing.
class DocumentStarts final : public YAML::EventHandler {
 public:
  int count = 0;
  YAML::Mark second;
  void OnDocumentStart(const YAML::Mark& mark) override {
    if (++count == 2) second = mark;
  }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnAlias(const YAML::Mark&, YAML::anchor_t) override {}
  void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t, const std::string&) override {}
  void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {}
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {}
  void OnMapEnd() override {}
};
}  // namespace

/// What yaml-cpp's message leaves out, for causes users meet (red team, session 30): a tab indenting the line
/// (Windows editors), a Python object dumped by yaml.dump (its !!python/ tag, a NumPy scalar's !!binary block), a
/// JSON string's UTF-16 surrogate escapes (json.dumps' default for an emoji).
static std::string syntax_hint(const std::string& text, const YAML::Exception& e) {
  std::vector<std::string> lines;
  {
    std::stringstream in(text);
    for (std::string l; std::getline(in, l);) lines.push_back(l);
  }
  if (e.mark.line >= 0 && static_cast<std::size_t>(e.mark.line) < lines.size()) {
    const std::string& l = lines[static_cast<std::size_t>(e.mark.line)];
    const auto indent = l.find_first_not_of(" ");
    if (indent != std::string::npos && l[indent] == '\t')
      return fmt::format("; line {} is indented with a tab: YAML indents with spaces", e.mark.line + 1);
  }
  if (text.find("!!python/") != std::string::npos)
    return "; the file holds a Python object (a !!python/ tag: yaml.dump of a tuple or a NumPy value): write plain "
           "numbers and lists (float(), int(), .tolist(); yaml.safe_dump refuses the rest)";
  if (e.msg.find("invalid unicode") != std::string::npos)
    return "; a \\uD800-\\uDFFF escape is half of a UTF-16 pair, which YAML does not join (Python's json.dumps "
           "writes an emoji so: pass ensure_ascii=False)";
  return "";
}

static ConfigNode parse_impl(const std::string& text, const std::string& name) {
  auto file = std::make_shared<const std::string>(name);
  // A carriage return that does not end a CRLF line: old-Mac line endings ("illegal map value" at some column of
  // line 1), or a last line of a CRLF file ending in CR alone ("unknown algorithm 'random\r'"; audit, session 44).
  for (std::size_t i = text.find('\r'); i != std::string::npos; i = text.find('\r', i + 1))
    if (i + 1 >= text.size() || text[i + 1] != '\n') {
      const std::size_t line = static_cast<std::size_t>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(i), '\n'));
      const std::size_t start = text.rfind('\n', i == 0 ? 0 : i - 1);
      const std::size_t column = start == std::string::npos || start > i ? i : i - start - 1;
      throw ConfigError(fmt::format("{}:{}:{}: a carriage return (CR) that does not end a CRLF line (old Mac line "
                                    "endings?); save the file with LF (Unix) or CRLF (Windows) line endings",
                                    name, line + 1, column + 1));
    }
  // A raw NUL byte: yaml-cpp said "unknown escape character" a line below it (audit, session 49). A configuration
  // is text; a NUL is binary data or a stray write.
  // Not in UTF-16 or UTF-32, which the YAML reader decodes (a BOM, or a NUL among the first two bytes: yaml-cpp's
  // own test of the encoding).
  const bool wide = text.size() >= 2 && (text[0] == '\0' || text[1] == '\0' || text.compare(0, 2, "\xFF\xFE") == 0 ||
                                         text.compare(0, 2, "\xFE\xFF") == 0);
  if (const std::size_t i = wide ? std::string::npos : text.find('\0'); i != std::string::npos) {
    const auto line = static_cast<std::size_t>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(i), '\n'));
    const std::size_t start = i == 0 ? std::string::npos : text.rfind('\n', i - 1);
    const std::size_t column = start == std::string::npos ? i : i - start - 1;
    throw ConfigError(fmt::format("{}:{}:{}: a NUL byte (\\0); a configuration is text (binary data, or a file "
                                  "cut or overwritten?)",
                                  name, line + 1, column + 1));
  }
  YAML::Node root;
  try {
    // At most two documents are looked at: yaml-cpp 0.7's LoadAll never ends on a stray ',' after the document
    // (`{type: gp},` as a flag, a trailing comma in a file: each call returns another empty document), growing
    // ~200 MB/s until bad_alloc (red team, session 27; jbeder/yaml-cpp#1040).
    std::stringstream in(text);
    YAML::Parser parser(in);
    DocumentStarts starts;
    for (int i = 0; i < 2 && parser.HandleNextDocument(starts); ++i) {
    }
    if (starts.count > 1)
      throw ConfigError(fmt::format("{}: a second YAML document (after '---', or text after the end of the first "
                                    "such as a stray ','); a configuration holds one",
                                    at(name, starts.second)));
    root = YAML::Load(text);
  } catch (const YAML::DeepRecursion& e) {
    // yaml-cpp's own message for this is "bad file" (audit, session 44).
    throw ConfigError(fmt::format("{}:{}:{}: YAML nested too deeply here (lists or maps inside one another, "
                                  "hundreds of levels; the YAML reader stops at {} of its levels): a configuration "
                                  "nests a few",
                                  name, e.mark.line + 1, e.mark.column + 1, e.depth()));
  } catch (const YAML::Exception& e) {
    throw ConfigError(fmt::format("{}:{}:{}: YAML syntax error: {}{}", name, e.mark.line + 1, e.mark.column + 1,
                                  e.msg, syntax_hint(text, e)));
  }
  WalkBudget merging, checking;
  resolve_merge_keys(root, name, 0, merging);
  check_structure(root, name, 0, checking);
  return ConfigNode(root, file, "");
}

ConfigNode ConfigNode::load_file(const std::string& filename) {
  // Only a regular file (or a link to one): opening a FIFO or a device would block or read forever.
  if (const auto k = irregular_file_kind(filename))
    throw ConfigError(fmt::format("{}: not a regular file ({}; expected a YAML configuration file)", filename, *k));
  std::ifstream in(filename);
  if (!in) throw ConfigError(fmt::format("{}: cannot open configuration file", filename));
  std::stringstream ss;
  ss << in.rdbuf();
  ConfigNode n = parse_impl(ss.str(), filename);
  if (!n.is_map()) throw ConfigError(fmt::format("{}:1:1: expected a YAML map of settings at the top level", filename));
  return n;
}

ConfigNode ConfigNode::parse(const std::string& text, const std::string& name) { return parse_impl(text, name); }

std::string ConfigNode::where() const {
  if (!has_mark_) return *file_;
  return fmt::format("{}:{}:{}", *file_, mark_.line + 1, mark_.column + 1);
}

bool ConfigNode::has(const std::string& key) const {
  return node_.IsMap() && node_[key].IsDefined();
}

ConfigNode ConfigNode::child(const std::string& key) const {
  std::string p = path_.empty() ? key : path_ + "." + key;
  YAML::Node c = node_.IsMap() ? node_[key] : YAML::Node(YAML::NodeType::Undefined);
  ConfigNode out(c, file_, p);
  if (!out.has_mark_) {
    out.mark_ = mark_;
    out.has_mark_ = has_mark_;
  }
  return out;
}

ConfigNode ConfigNode::item(std::size_t i) const {
  ConfigNode out(node_[i], file_, fmt::format("{}[{}]", path_, i));
  if (!out.has_mark_) {
    out.mark_ = mark_;
    out.has_mark_ = has_mark_;
  }
  return out;
}

std::vector<std::string> ConfigNode::keys() const {
  std::vector<std::string> out;
  if (!node_.IsMap()) return out;
  for (const auto& kv : node_) out.push_back(kv.first.as<std::string>());
  return out;
}

std::string ConfigNode::scalar() const { return node_.IsScalar() ? node_.Scalar() : std::string(); }

void ConfigNode::fail(const std::string& message) const {
  if (path_.empty()) throw ConfigError(fmt::format("{}: {}", where(), message));
  throw ConfigError(fmt::format("{}: key '{}': {}", where(), path_, message));
}

static std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

std::string closest_match(const std::string& word, const std::vector<std::string>& candidates) {
  // No name is this long; the edit distances of a 10 MB value took most of a minute.
  if (word.size() > 200) return {};
  // A candidate that extends the word ("matern52" -> "matern52_ard") is the likeliest intent.
  for (const auto& c : candidates)
    if (word.size() >= 3 && c.rfind(word, 0) == 0) return c;
  // Then one that ends with it after a '_' ("lbfgs" -> "ceres_lbfgs", "ard" is too short to count).
  for (const auto& c : candidates)
    if (word.size() >= 4 && c.size() > word.size() && c.compare(c.size() - word.size(), word.size(), word) == 0 &&
        c[c.size() - word.size() - 1] == '_')
      return c;
  std::string best;
  std::size_t best_d = std::string::npos;
  for (const auto& c : candidates) {
    const std::size_t d = edit_distance(word, c);
    if (d < best_d) {
      best_d = d;
      best = c;
    }
  }
  // A candidate that shares no character position with the word is no near miss ("1" -> "pd" was suggested).
  if (best_d <= std::max<std::size_t>(2, word.size() / 3) && best_d < word.size()) return best;
  return {};
}

std::string join(const std::vector<std::string>& items, const std::string& sep) {
  std::string out;
  for (std::size_t i = 0; i < items.size(); ++i) out += (i ? sep : "") + items[i];
  return out;
}

std::vector<std::string> distinct_names(const ConfigNode& list, const std::string& what) {
  if (!list.is_sequence() || list.size() == 0) list.fail(fmt::format("expected a non-empty list of {} names", what));
  std::vector<std::string> out;
  std::set<std::string> seen;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const ConfigNode item = list.item(i);
    if (!item.is_scalar() || item.scalar().empty()) item.fail(fmt::format("expected a {} name", what));
    if (!seen.insert(item.scalar()).second) item.fail(fmt::format("duplicate name '{}'", item.scalar()));
    // A parameter named `cost` gave trials.csv two `cost` columns, and a reader took the first (the θ value).
    if (what == "parameter" && is_trials_table_column(item.scalar()))
      item.fail(trials_column_clash(item.scalar(), "parameter"));
    out.push_back(item.scalar());
  }
  return out;
}

std::vector<std::string> cost_component_names(const ConfigNode& list) {
  std::vector<std::string> out = distinct_names(list, "cost component");
  for (std::size_t i = 0; i < out.size(); ++i)
    if (is_trials_table_column(out[i]))
      list.item(i).fail(trials_column_clash(out[i], "component"));
  return out;
}

}  // namespace varbo
