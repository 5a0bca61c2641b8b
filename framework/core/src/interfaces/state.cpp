// StateMap: YAML text of a snapshot, with every number in its shortest round-trip form (fmt's "{}"), so that
// a restored state is bit-for-bit the saved one. A vector (and a matrix's values) is one scalar of numbers
// separated by spaces, not a YAML list: one node instead of one per number. A GP's state holds its N × d data,
// and a node per number made emitting and parsing it ~9 % of a `varbo suggest` (docs/studies.md). The list form
// of states saved before is still read.
#include "varbo/state.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <iterator>
#include <optional>
#include <vector>

#include "state_reader.hpp"
#include "varbo/errors.hpp"
#include "varbo/numbers.hpp"

namespace varbo {

ComponentState::~ComponentState() = default;
AlgorithmState::~AlgorithmState() = default;

namespace {
std::string number(double v) { return fmt::format("{}", v); }

bool read_number(const YAML::Node& n, double& out) {
  if (!n.IsScalar()) return false;
  const std::string& s = n.Scalar();
  if (s.empty()) return false;
  char* end = nullptr;
  errno = 0;
  out = strtod_c(s.c_str(), &end);  // reads "nan", "inf", "-inf" too: a state may hold them
  return end == s.c_str() + s.size();
}

/// n numbers as one scalar, "v1 v2 ..."; an empty list stays a YAML list ([]), which has() sees as a value.
YAML::Node numbers_node(const double* v, Index n) {
  if (n == 0) return YAML::Node(YAML::NodeType::Sequence);
  fmt::memory_buffer out;
  for (Index i = 0; i < n; ++i) {
    if (i) out.push_back(' ');
    fmt::format_to(std::back_inserter(out), "{}", v[i]);
  }
  return YAML::Node(fmt::to_string(out));
}

/// The numbers of a node written by numbers_node, or of a YAML list of numbers (states saved before).
bool read_numbers(const YAML::Node& n, Vec& out) {
  std::vector<double> values;
  if (n.IsSequence()) {
    values.resize(n.size());
    for (std::size_t i = 0; i < n.size(); ++i)
      if (!read_number(n[i], values[i])) return false;
  } else if (n.IsScalar()) {
    const char* p = n.Scalar().c_str();
    while (*p) {
      if (*p == ' ') {
        ++p;
        continue;
      }
      char* end = nullptr;
      const double v = strtod_c(p, &end);
      if (end == p || (*end != ' ' && *end != '\0')) return false;
      values.push_back(v);
      p = end;
    }
  } else {
    return false;
  }
  out = Eigen::Map<const Vec>(values.data(), static_cast<Index>(values.size()));
  return true;
}
}  // namespace

StateMap::StateMap() : node_(YAML::NodeType::Map), what_("state") {}
StateMap::StateMap(YAML::Node node, std::string what) : node_(std::move(node)), what_(std::move(what)) {}

namespace detail {
namespace {
/// Reads the one-line flow YAML that StateMap::text() writes — maps, sequences, plain scalars of letters,
/// digits and ". _ + - /" (numbers, words, vectors of numbers), single- and double-quoted scalars of printable
/// ASCII (double-quoted with the escapes \\ \" \n \t \r \/ \xHH) — into the nodes YAML::Load would build.
/// Anything else (another layout, a comment, a tag, non-ASCII text, a duplicate key) ends it: the caller
/// falls back to YAML::Load. yaml-cpp's scanner tests every character of a scalar against several patterns,
/// which made parsing a GP's saved state (its data as one scalar per vector, the surrogate's state as a quoted
/// text parsed again) ~12 % of opening a study (docs/studies.md); this reader makes one pass.
class FlowReader {
 public:
  explicit FlowReader(const std::string& text) : p_(text.data()), end_(text.data() + text.size()) {}

  std::optional<YAML::Node> document() {
    space();
    if (p_ == end_ || *p_ != '{') return std::nullopt;
    std::optional<YAML::Node> n = value();
    while (p_ != end_ && (*p_ == ' ' || *p_ == '\n')) ++p_;
    if (!n || p_ != end_) return std::nullopt;
    return n;
  }

 private:
  void space() {
    while (p_ != end_ && *p_ == ' ') ++p_;
  }
  bool at(char c) const { return p_ != end_ && *p_ == c; }

  /// After an item of a flow collection: its closing bracket (consumed), a comma (consumed with the spaces after
  /// it: another item follows) or anything else (not the writer's format).
  enum class After { Close, More, Bad };
  After after_item(char close) {
    space();
    if (at(close)) {
      ++p_;
      return After::Close;
    }
    if (!at(',')) return After::Bad;
    ++p_;
    space();
    return After::More;
  }

  std::optional<YAML::Node> value() {
    if (p_ == end_) return std::nullopt;
    if (++depth_ > 64) return std::nullopt;
    std::optional<YAML::Node> out;
    switch (*p_) {
      case '{': out = map(); break;
      case '[': out = sequence(); break;
      case '"': out = double_quoted(); break;
      case '\'': out = single_quoted(); break;
      default: out = plain(); break;
    }
    --depth_;
    return out;
  }

  std::optional<YAML::Node> map() {
    ++p_;  // '{'
    YAML::Node m(YAML::NodeType::Map);
    std::vector<std::string> keys;
    space();
    if (at('}')) {
      ++p_;
      return m;
    }
    for (;;) {
      std::optional<YAML::Node> key = at('"') ? double_quoted() : at('\'') ? single_quoted() : plain();
      if (!key || !key->IsScalar()) return std::nullopt;
      const std::string k = key->Scalar();
      if (std::find(keys.begin(), keys.end(), k) != keys.end()) return std::nullopt;
      keys.push_back(k);
      space();
      if (!at(':')) return std::nullopt;
      ++p_;
      if (!at(' ') && !at(',') && !at('}')) return std::nullopt;
      space();
      if (at(',') || at('}')) {
        m[k] = YAML::Node(YAML::NodeType::Null);
      } else {
        std::optional<YAML::Node> v = value();
        if (!v) return std::nullopt;
        m[k] = *v;
      }
      const After next = after_item('}');
      if (next == After::Close) return m;
      if (next == After::Bad) return std::nullopt;
    }
  }

  std::optional<YAML::Node> sequence() {
    ++p_;  // '['
    YAML::Node s(YAML::NodeType::Sequence);
    space();
    if (at(']')) {
      ++p_;
      return s;
    }
    for (;;) {
      if (at(',') || at(']')) return std::nullopt;
      std::optional<YAML::Node> v = value();
      if (!v) return std::nullopt;
      s.push_back(*v);
      const After next = after_item(']');
      if (next == After::Close) return s;
      if (next == After::Bad) return std::nullopt;
    }
  }

  static bool plain_char(char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' || c == '_' ||
           c == '+' || c == '-' || c == '/';
  }

  std::optional<YAML::Node> plain() {
    const char* begin = p_;
    // A plain scalar cannot start with a space, and "- " would be a block sequence entry.
    if (p_ == end_ || !plain_char(*p_)) return std::nullopt;
    if (*p_ == '-' && (p_ + 1 == end_ || !plain_char(p_[1]))) return std::nullopt;
    const char* last = p_;  // one past the last character that is not a space
    while (p_ != end_ && (plain_char(*p_) || *p_ == ' ')) {
      if (*p_ != ' ') last = p_ + 1;
      ++p_;
    }
    if (p_ != end_ && *p_ != ',' && *p_ != '}' && *p_ != ']' && *p_ != ':') return std::nullopt;
    p_ = last;  // the spaces before an indicator are not part of the scalar
    std::string v(begin, last);
    if (v == "~" || v == "null" || v == "Null" || v == "NULL") return YAML::Node(YAML::NodeType::Null);
    return YAML::Node(v);
  }

  static int hex(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
  }
  static bool printable(char c) { return c >= 0x20 && c < 0x7f; }

  std::optional<YAML::Node> double_quoted() {
    ++p_;  // '"'
    std::string v;
    while (p_ != end_ && *p_ != '"') {
      const char c = *p_++;
      if (!printable(c)) return std::nullopt;
      if (c != '\\') {
        v.push_back(c);
        continue;
      }
      if (p_ == end_) return std::nullopt;
      switch (const char e = *p_++) {
        case '\\': v.push_back('\\'); break;
        case '"': v.push_back('"'); break;
        case '/': v.push_back('/'); break;
        case 'n': v.push_back('\n'); break;
        case 't': v.push_back('\t'); break;
        case 'r': v.push_back('\r'); break;
        case 'x': {
          if (end_ - p_ < 2) return std::nullopt;
          const int hi = hex(p_[0]), lo = hex(p_[1]);
          if (hi < 0 || lo < 0 || hi > 7) return std::nullopt;  // ASCII only
          v.push_back(static_cast<char>(16 * hi + lo));
          p_ += 2;
          break;
        }
        default:
          (void)e;
          return std::nullopt;
      }
    }
    if (p_ == end_) return std::nullopt;
    ++p_;  // '"'
    return YAML::Node(v);
  }

  std::optional<YAML::Node> single_quoted() {
    ++p_;  // '\''
    std::string v;
    for (;;) {
      if (p_ == end_) return std::nullopt;
      const char c = *p_++;
      if (!printable(c)) return std::nullopt;
      if (c == '\'') {
        if (at('\'')) {
          v.push_back('\'');
          ++p_;
          continue;
        }
        return YAML::Node(v);
      }
      v.push_back(c);
    }
  }

  const char* p_;
  const char* end_;
  int depth_ = 0;
};
}  // namespace

std::optional<YAML::Node> read_flow_state(const std::string& text) { return FlowReader(text).document(); }
}  // namespace detail

StateMap StateMap::parse(const std::string& text, const std::string& what) {
  if (std::optional<YAML::Node> n = detail::read_flow_state(text)) return StateMap(*n, what);
  YAML::Node n;
  try {
    n = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(fmt::format("{}: unreadable saved state ({})", what, e.what()));
  }
  if (!n.IsMap()) throw InputError(fmt::format("{}: unreadable saved state (expected a map)", what));
  return StateMap(n, what);
}

std::string StateMap::text() const {
  YAML::Emitter em;
  em << YAML::Flow << node_;
  return em.c_str();
}

void StateMap::put(const std::string& key, double v) { node_[key] = number(v); }
void StateMap::put_int(const std::string& key, long long v) { node_[key] = std::to_string(v); }
void StateMap::put(const std::string& key, bool v) { node_[key] = v ? "true" : "false"; }
void StateMap::put(const std::string& key, const std::string& v) { node_[key] = v; }
void StateMap::put(const std::string& key, const Vec& v) { node_[key] = numbers_node(v.data(), v.size()); }
void StateMap::put(const std::string& key, const Mat& m) {
  YAML::Node s(YAML::NodeType::Map);
  s["rows"] = std::to_string(m.rows());
  s["cols"] = std::to_string(m.cols());
  const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> by_rows = m;  // row after row
  s["values"] = numbers_node(by_rows.data(), by_rows.size());
  node_[key] = s;
}
void StateMap::put(const std::string& key, const StateMap& child) { node_[key] = YAML::Clone(child.node_); }
void StateMap::put(const std::string& key, const std::vector<Vec>& rows) {
  YAML::Node s(YAML::NodeType::Sequence);
  for (const Vec& v : rows) s.push_back(numbers_node(v.data(), v.size()));
  node_[key] = s;
}

void StateMap::put(const std::string& key, const ModelSnapshot& s) {
  StateMap m;
  m.put_int("iteration", s.iteration);
  m.put("objective", s.objective);
  m.put("note", s.note);
  m.put("region_state", s.region_state);
  YAML::Node names(YAML::NodeType::Sequence);
  Vec values(static_cast<Index>(s.hyperparameters.size()));
  for (std::size_t i = 0; i < s.hyperparameters.size(); ++i) {
    names.push_back(s.hyperparameters[i].name);
    values[static_cast<Index>(i)] = s.hyperparameters[i].value;
  }
  m.node_["hyperparameter_names"] = names;
  m.put("hyperparameters", values);
  put(key, m);
}

ModelSnapshot StateMap::model_snapshot(const std::string& key) const {
  const StateMap m = map(key);
  ModelSnapshot s;
  s.iteration = static_cast<Index>(m.integer("iteration"));
  s.objective = m.real("objective");
  s.note = m.str("note");
  s.region_state = m.str("region_state");
  const Vec values = m.vec("hyperparameters");
  const YAML::Node names = m.at("hyperparameter_names");
  if (!names.IsSequence() || static_cast<Index>(names.size()) != values.size())
    m.fail("hyperparameter_names", "one name per hyperparameter");
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (!names[i].IsScalar()) m.fail("hyperparameter_names", "names");
    s.hyperparameters.push_back({names[i].Scalar(), values[static_cast<Index>(i)]});
  }
  return s;
}

bool StateMap::has(const std::string& key) const { return node_[key].IsDefined() && !node_[key].IsNull(); }

YAML::Node StateMap::at(const std::string& key) const {
  const YAML::Node n = node_[key];
  if (!n.IsDefined() || n.IsNull()) fail(key, "a value");
  return n;
}

void StateMap::fail(const std::string& key, const std::string& expected) const {
  throw InputError(fmt::format("{}: saved state key '{}': expected {} (a state written by another version?)", what_,
                               key, expected));
}

double StateMap::real(const std::string& key) const {
  double v = 0;
  if (!read_number(at(key), v)) fail(key, "a number");
  return v;
}
long long StateMap::integer(const std::string& key) const {
  const YAML::Node n = at(key);
  if (!n.IsScalar()) fail(key, "an integer");
  char* end = nullptr;
  const long long v = std::strtoll(n.Scalar().c_str(), &end, 10);
  if (n.Scalar().empty() || *end != '\0') fail(key, "an integer");
  return v;
}
bool StateMap::boolean(const std::string& key) const {
  const YAML::Node n = at(key);
  if (n.IsScalar() && n.Scalar() == "true") return true;
  if (n.IsScalar() && n.Scalar() == "false") return false;
  fail(key, "true or false");
}
std::string StateMap::str(const std::string& key) const {
  const YAML::Node n = node_[key];
  if (!n.IsDefined() || n.IsNull()) return {};
  if (!n.IsScalar()) fail(key, "a string");
  return n.Scalar();
}
Vec StateMap::vec(const std::string& key) const {
  Vec v;
  if (!read_numbers(at(key), v)) fail(key, "a list of numbers");
  return v;
}
Mat StateMap::mat(const std::string& key) const {
  const YAML::Node n = at(key);
  if (!n.IsMap()) fail(key, "a matrix {rows, cols, values}");
  const StateMap m(n, what_ + "/" + key);
  const long long r = m.integer("rows"), c = m.integer("cols");
  const Vec values = m.vec("values");
  if (r < 0 || c < 0 || values.size() != r * c) fail(key, "rows × cols values");
  Mat out(r, c);
  for (Index i = 0; i < r; ++i)
    for (Index j = 0; j < c; ++j) out(i, j) = values[i * c + j];
  return out;
}
StateMap StateMap::map(const std::string& key) const {
  const YAML::Node n = at(key);
  if (!n.IsMap()) fail(key, "a map");
  return StateMap(n, what_ + "/" + key);
}
std::vector<Vec> StateMap::rows(const std::string& key) const {
  const YAML::Node n = at(key);
  if (!n.IsSequence()) fail(key, "a list of lists of numbers");
  std::vector<Vec> out;
  for (std::size_t r = 0; r < n.size(); ++r) {
    Vec v;
    if (!read_numbers(n[r], v)) fail(key, "a list of lists of numbers");
    out.push_back(std::move(v));
  }
  return out;
}

}  // namespace varbo
