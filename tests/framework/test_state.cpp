// StateMap (varbo/state.hpp): the text of a saved algorithm state reads back bit-for-bit, in the current form
// (a vector is one scalar of numbers) and in the list form of states saved by earlier versions.
#include <cmath>
#include <cstring>
#include <limits>

#include "../../framework/core/src/interfaces/state_reader.hpp"  // the one-pass reader (internal)
#include "varbo/errors.hpp"
#include "varbo/state.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {
bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }
bool same_bits(const Vec& a, const Vec& b) {
  if (a.size() != b.size()) return false;
  for (Index i = 0; i < a.size(); ++i)
    if (!same_bits(a[i], b[i])) return false;
  return true;
}
}  // namespace

TEST_CASE("StateMap: vectors, matrices and rows read back bit-for-bit, awkward values included") {
  Vec v(9);
  v << 0.1, -0.0, 1e-300, std::numeric_limits<double>::denorm_min(), -1.7976931348623157e308,
      std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(), 1.0 / 3.0, -2.5e-7;
  Mat m(3, 2);
  m << 1.0 / 7.0, 2.0, -3.25, 4e10, 5e-5, -6.0;
  StateMap s;
  s.put("v", v);
  s.put("m", m);
  s.put("one", Vec(Vec::Constant(1, 0.7)));
  s.put("none", Vec());
  s.put("rows", std::vector<Vec>{v, Vec(), Vec::Constant(2, -1.5)});
  s.put("nan", Vec(Vec::Constant(2, std::nan(""))));
  const StateMap r = StateMap::parse(s.text(), "test state");
  CHECK(same_bits(r.vec("v"), v));
  const Mat m2 = r.mat("m");
  REQUIRE(m2.rows() == 3);
  REQUIRE(m2.cols() == 2);
  for (Index i = 0; i < 3; ++i)
    for (Index j = 0; j < 2; ++j) CHECK(same_bits(m2(i, j), m(i, j)));
  CHECK(same_bits(r.vec("one"), Vec::Constant(1, 0.7)));
  CHECK(r.has("none"));
  CHECK(r.vec("none").size() == 0);
  const auto rows = r.rows("rows");
  REQUIRE(rows.size() == 3);
  CHECK(same_bits(rows[0], v));
  CHECK(rows[1].size() == 0);
  CHECK(same_bits(rows[2], Vec::Constant(2, -1.5)));
  const Vec nan = r.vec("nan");
  REQUIRE(nan.size() == 2);
  CHECK(std::isnan(nan[0]));
  CHECK(std::isnan(nan[1]));
  // Saving what was read gives the same text (varbo study verify compares texts).
  StateMap again;
  again.put("v", r.vec("v"));
  StateMap first;
  first.put("v", v);
  CHECK(again.text() == first.text());
}

TEST_CASE("StateMap: the list form of earlier versions reads to the same values; malformed numbers are refused") {
  const StateMap old = StateMap::parse(
      "{v: [0.1, -0.0, 1e-300, inf], m: {rows: 2, cols: 2, values: [1, 2, 3, 4]}, rows: [[1.5, 2], []]}", "old state");
  Vec v(4);
  v << 0.1, -0.0, 1e-300, std::numeric_limits<double>::infinity();
  CHECK(same_bits(old.vec("v"), v));
  const Mat m = old.mat("m");
  CHECK(m(0, 1) == 2.0);
  CHECK(m(1, 0) == 3.0);
  const auto rows = old.rows("rows");
  REQUIRE(rows.size() == 2);
  CHECK(rows[0].size() == 2);
  CHECK(rows[0][1] == 2.0);
  CHECK(rows[1].size() == 0);
  // The current form: one scalar per vector, which the old reader would have refused.
  StateMap s;
  s.put("v", v);
  CHECK(s.text().find("[") == std::string::npos);
  const StateMap bad = StateMap::parse("{v: 1.5 x 2, w: '1.5,2', u: {a: 1}}", "bad state");
  CHECK_THROWS_WITH_AS(bad.vec("v"), doctest::Contains("bad state: saved state key 'v': expected a list of numbers"),
                       InputError);
  CHECK_THROWS_AS(bad.vec("w"), InputError);
  CHECK_THROWS_AS(bad.vec("u"), InputError);
}

namespace {
/// Same node tree: types, scalars, keys in order.
bool same_tree(const YAML::Node& a, const YAML::Node& b, std::string& where) {
  if (a.Type() != b.Type()) {
    where += " (type)";
    return false;
  }
  if (a.IsScalar()) {
    if (a.Scalar() != b.Scalar()) where += " (scalar '" + a.Scalar() + "' vs '" + b.Scalar() + "')";
    return a.Scalar() == b.Scalar();
  }
  if (a.size() != b.size()) {
    where += " (size)";
    return false;
  }
  if (a.IsSequence()) {
    for (std::size_t i = 0; i < a.size(); ++i) {
      where.append("/").append(std::to_string(i));
      if (!same_tree(a[i], b[i], where)) return false;
    }
    return true;
  }
  auto ia = a.begin(), ib = b.begin();
  for (; ia != a.end(); ++ia, ++ib) {
    if (!ia->first.IsScalar() || !ib->first.IsScalar() || ia->first.Scalar() != ib->first.Scalar()) {
      where += " (key)";
      return false;
    }
    where.append("/").append(ia->first.Scalar());
    if (!same_tree(ia->second, ib->second, where)) return false;
  }
  return true;
}

/// The one-pass reader either declines (nullopt) or builds exactly the nodes YAML::Load builds.
void check_reader(const std::string& text, bool must_read) {
  INFO(text);
  const std::optional<YAML::Node> fast = detail::read_flow_state(text);
  if (must_read) CHECK(fast.has_value());
  if (!fast) return;
  YAML::Node slow;
  try {
    slow = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    FAIL_CHECK("the reader read a text YAML::Load refuses: " << e.what());
    return;
  }
  std::string where;
  CHECK_MESSAGE(same_tree(*fast, slow, where), where);
}
}  // namespace

TEST_CASE("StateMap: the one-pass reader builds the nodes YAML::Load builds, or declines") {
  // Texts StateMap::text() writes, with awkward strings: each must read as YAML::Load reads it.
  const std::vector<std::string> strings = {
      "", " ", "plain", "two words", "  leading", "trailing  ", "null", "~", "Null", "NULL", "true", "- x", "-",
      "-1.5", "a: b", "a:b", "#c", "a #c", "[x]", "{y}", "x, y", "\"q\"", "'s'", "back\\slash", "new\nline",
      "tab\there", "cr\rx", "bell\x07", "del\x7f", "θ = 1", "a/b", "1e-300 -0 inf -inf nan", "?", "? x", "!tag",
      "&a", "*a", "%p", "@x", "`x`", "|", ">", "=", "x\\\"y", "é", "\x01\x1f", "...", "---", "a  b   c"};
  StateMap inner;
  inner.put("v", Vec(Vec::LinSpaced(7, -3.0, 4.0 / 3.0)));
  inner.put_int("n", 40);
  StateMap s;
  for (std::size_t i = 0; i < strings.size(); ++i) {
    s.put(std::string("k").append(std::to_string(i)), strings[i]);
    StateMap one;
    one.put("value", strings[i]);
    one.put(strings[i].empty() ? std::string("empty") : strings[i], 1.5);  // as a key too
    check_reader(one.text(), false);
  }
  s.put("inner_text", inner.text());
  s.put("inner_map", inner);
  s.put("m", Mat(Mat::Identity(3, 2)));
  s.put("rows", std::vector<Vec>{Vec::Constant(2, 0.25), Vec()});
  s.put("empty", Vec());
  s.put("flag", true);
  s.put("x", 1.0 / 3.0);
  check_reader(s.text(), false);
  check_reader(inner.text(), true);  // the common case: numbers, words
  StateMap typical;
  typical.put("surrogate", inner.text());
  typical.put("region", inner.text());
  typical.put("note", std::string());
  typical.put("region_state", std::string("L 0.8, successes 0/3, failures 1/6, restarts 1"));
  check_reader(typical.text(), true);
  // Hand-written texts: other layouts are declined or read as YAML::Load reads them.
  for (const char* t : {"{}", "{a: }", "{a: , b: 1}", "{a: [], b: {}}", "{a: [1, 2], b: {c: d}}", "{a: 1, a: 2}",
                        "{a:1}", "{\"a\":1}", "{a: 1} # c", "{a: 1}\n", "  {a: 1}", "{a: 1,}", "{a: [1,]}",
                        "{a: 'it''s'}", "{a: \"\\x41\\/\"}", "{a: \"\\u0041\"}", "{a: \"x\ny\"}", "{a: 'x\ny'}",
                        "{a: b c  }", "{a: -b}", "{a: - b}", "{a: .5}", "{a: +1}", "{? a: 1}", "{a: !!str 1}",
                        "{a: &x 1, b: *x}", "[1, 2]", "a: 1", "{a: {b: {c: {d: [[[]]]}}}}", "{a: 1}}", "{a: \"x"})
    check_reader(t, false);
  // And a state read either way restores the same values.
  const StateMap r = StateMap::parse(s.text(), "test state");
  CHECK(r.str("inner_text") == inner.text());
  CHECK(r.str("k0").empty());
  CHECK(r.str("k6") == "null");
  CHECK(r.boolean("flag"));
}
