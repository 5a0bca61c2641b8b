// The SVG writer of `varbo plot` (varbo/svg_plot.hpp).
#include <regex>

#include "varbo/svg_plot.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {
std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto p = text.find(what); p != std::string::npos; p = text.find(what, p + what.size())) ++n;
  return n;
}
}  // namespace

TEST_CASE("nice_ticks: round steps inside the range") {
  const std::vector<double> fifths = svg::nice_ticks(0, 1, 5);
  REQUIRE(fifths.size() == 6);
  for (std::size_t i = 0; i < 6; ++i) CHECK(fifths[i] == doctest::Approx(0.2 * static_cast<double>(i)));
  const auto t = svg::nice_ticks(-0.13, 1.07, 6);
  REQUIRE(t.size() >= 4);
  CHECK(t.front() >= -0.13);
  CHECK(t.back() <= 1.07);
  CHECK(t[1] - t[0] == doctest::Approx(0.25));
  CHECK(svg::nice_ticks(1, 1, 5).empty());  // empty range: no ticks, no loop
  CHECK(svg::nice_ticks(0, NAN, 5).empty());
}

TEST_CASE("colormap and escape") {
  CHECK(svg::colormap(0) == "#440154");  // viridis end points
  CHECK(svg::colormap(1) == "#fde725");
  CHECK(svg::colormap(NAN) == svg::colormap(0));
  CHECK(svg::escape("a<b & \"c\">") == "a&lt;b &amp; &quot;c&quot;&gt;");
  // XML takes no control character: a label holding ESC made a file browsers refused (red team, session 31).
  CHECK(svg::escape("\x1B[31mred\x01") == "\\x1B[31mred\\x01");
  CHECK(svg::escape("caf\xC3\xA9 \xFF") == "caf\xC3\xA9 \\xFF");
}

TEST_CASE("a figure renders well-formed SVG with one element per marker") {
  svg::Figure fig(400, 300, "t <1>");
  svg::Panel& p = fig.panel(60, 40, 300, 200, {0, 1}, {-1, 1});
  p.labels("x", "y", "panel");
  p.band({0, 0.5, 1}, {-0.5, -0.4, -0.3}, {0.5, 0.4, 0.3}, "#cccccc", 0.3, "band");
  p.line({0, 0.5, 1}, {0, 0.1, NAN}, "#000000", 1.5, "4 2", "line");
  p.markers({0.1, 0.2, 0.3, NAN}, {0, 0, 0, 0}, svg::Marker::Circle, "#0000ff", 3, "data", "data");
  p.vline(0.4, "#ff0000", "3 3", "rule");
  Mat z(3, 4);
  z.setRandom();
  svg::Panel& q = fig.panel(60, 260, 100, 30, {0, 1}, {0, 1});
  q.heatmap(z, "z");
  const std::string s = fig.render();
  CHECK(s.rfind("<svg xmlns=\"http://www.w3.org/2000/svg\"", 0) == 0);
  CHECK(s.find("</svg>\n") == s.size() - 7);
  CHECK(count(s, "class=\"data\"") == 3);  // the NaN marker is skipped
  CHECK(count(s, "<g") == count(s, "</g>"));
  CHECK(s.find("t &lt;1&gt;") != std::string::npos);
  CHECK(count(s, "fill=\"#") >= 12);  // 12 heat-map cells at least
  // Every attribute value is quoted and no NaN leaked into coordinates.
  // ("dominant-baseline" contains "nan": match whole words only.)
  CHECK_FALSE(std::regex_search(s, std::regex("[^a-z](nan|inf)[^a-z]")));
}
