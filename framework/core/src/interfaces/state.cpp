// StateMap: YAML text of a snapshot, with every number in its shortest round-trip form (fmt's "{}"), so that
// a restored state is bit-for-bit the saved one. A vector (and a matrix's values) is one scalar of numbers
// separated by spaces, not a YAML list: one node instead of one per number. A GP's state holds its N × d data,
// and a node per number made emitting and parsing it ~9 % of a `varbo suggest` (docs/studies.md). The list form
// of states saved before is still read.
#include "varbo/state.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cstdlib>
#include <iterator>

#include "varbo/errors.hpp"

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
  out = std::strtod(s.c_str(), &end);  // reads "nan", "inf", "-inf" too: a state may hold them
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
      const double v = std::strtod(p, &end);
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

StateMap StateMap::parse(const std::string& text, const std::string& what) {
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
