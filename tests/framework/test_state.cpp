// StateMap (varbo/state.hpp): the text of a saved algorithm state reads back bit-for-bit, in the current form
// (a vector is one scalar of numbers) and in the list form of states saved by earlier versions.
#include <cmath>
#include <cstring>
#include <limits>

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
