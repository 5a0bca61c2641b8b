// Hand-written SVG for `varbo plot` (svg_plot.hpp). Text output only; every element is plain SVG 1.1.
#include "varbo/svg_plot.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>

#include "varbo/errors.hpp"
#include "varbo/text.hpp"

namespace varbo::svg {

namespace {
constexpr const char* kFont = "font-family=\"DejaVu Sans, Arial, sans-serif\"";

std::string num(double v) { return fmt::format("{:.2f}", v); }

std::string tick_label(double v, double step) {
  if (std::abs(v) < 1e-12 * std::max(1.0, step)) return "0";
  const double a = std::abs(v);
  if (a >= 1e5 || a < 1e-3) return fmt::format("{:.3g}", v);
  // Enough decimals to show the step exactly (0.25 needs 2, 0.2 needs 1).
  int decimals = 0;
  while (decimals < 8 && std::abs(std::round(step * std::pow(10.0, decimals)) - step * std::pow(10.0, decimals)) >
                             1e-6 * step * std::pow(10.0, decimals))
    ++decimals;
  return fmt::format("{:.{}f}", v, decimals);
}

std::string marker_svg(Marker shape, double x, double y, double r, const std::string& color, const std::string& cls) {
  const std::string c = cls.empty() ? std::string() : fmt::format(" class=\"{}\"", escape(cls));
  switch (shape) {
    case Marker::Circle:
      // A white marker (data on a heat map) gets a dark rim so it also shows on white (legend).
      return fmt::format("<circle{} cx=\"{}\" cy=\"{}\" r=\"{}\" fill=\"{}\" fill-opacity=\"0.85\" stroke=\"{}\" "
                         "stroke-width=\"0.6\"/>\n",
                         c, num(x), num(y), num(r), color, color == "#ffffff" ? "#333333" : "white");
    case Marker::Cross:
      return fmt::format("<path{} d=\"M{} {}L{} {}M{} {}L{} {}\" stroke=\"{}\" stroke-width=\"2\" fill=\"none\"/>\n", c,
                         num(x - r), num(y - r), num(x + r), num(y + r), num(x - r), num(y + r), num(x + r),
                         num(y - r), color);
    case Marker::Diamond:
      return fmt::format("<path{} d=\"M{} {}L{} {}L{} {}L{} {}Z\" fill=\"{}\" stroke=\"black\" stroke-width=\"0.8\"/>\n",
                         c, num(x), num(y - 1.3 * r), num(x + r), num(y), num(x), num(y + 1.3 * r), num(x - r),
                         num(y), color);
    case Marker::Triangle:
      return fmt::format("<path{} d=\"M{} {}L{} {}L{} {}Z\" fill=\"{}\" stroke=\"black\" stroke-width=\"0.8\"/>\n", c,
                         num(x), num(y - 1.2 * r), num(x + 1.1 * r), num(y + 0.8 * r), num(x - 1.1 * r),
                         num(y + 0.8 * r), color);
  }
  return {};
}
}  // namespace

std::vector<double> nice_ticks(double lo, double hi, int target) {
  std::vector<double> out;
  if (!(hi > lo) || !std::isfinite(lo) || !std::isfinite(hi) || target < 1) return out;
  const double raw = (hi - lo) / target;
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (double m : {1.0, 2.0, 2.5, 5.0, 10.0})
    if (m * mag >= raw) {
      step = m * mag;
      break;
    }
  const double first = std::ceil(lo / step - 1e-9) * step;
  for (double v = first; v <= hi + 1e-9 * step; v += step) out.push_back(std::abs(v) < 1e-12 * step ? 0.0 : v);
  return out;
}

Range padded(double lo, double hi, double pad) {
  if (!(hi > lo)) {
    const double h = lo == 0 ? 0.5 : std::abs(lo) / 2;
    return {lo - h, hi + h};
  }
  const double w = hi - lo;
  return {lo - pad * w, hi + pad * w};
}

std::string colormap(double t) {
  // Viridis at 9 evenly spaced stops (matplotlib's _viridis_data), linearly interpolated.
  static constexpr std::array<std::array<double, 3>, 9> stops = {{{0.267, 0.005, 0.329},
                                                                   {0.279, 0.175, 0.483},
                                                                   {0.230, 0.322, 0.546},
                                                                   {0.173, 0.449, 0.558},
                                                                   {0.128, 0.567, 0.551},
                                                                   {0.155, 0.683, 0.500},
                                                                   {0.360, 0.785, 0.388},
                                                                   {0.668, 0.862, 0.196},
                                                                   {0.993, 0.906, 0.144}}};
  if (!std::isfinite(t)) t = 0;
  t = std::clamp(t, 0.0, 1.0) * 8.0;
  const int i = std::min(7, static_cast<int>(t));
  const double f = t - i;
  auto channel = [&](int c) {
    return static_cast<int>(std::lround(255.0 * ((1 - f) * stops[static_cast<std::size_t>(i)][static_cast<std::size_t>(c)] +
                                                 f * stops[static_cast<std::size_t>(i + 1)][static_cast<std::size_t>(c)])));
  };
  return fmt::format("#{:02x}{:02x}{:02x}", channel(0), channel(1), channel(2));
}

std::string escape(const std::string& text) {
  std::string out;
  // printable(): XML allows no control character but tab and line breaks, and no invalid UTF-8; a label holding
  // ESC made an SVG browsers refuse (red team, session 31). Shown as \xHH instead.
  for (char c : printable(text)) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

// ---- Panel ----
Panel::Panel(int id, double left, double top, double width, double height, Range x, Range y)
    : id_(id), left_(left), top_(top), width_(width), height_(height), x_(x), y_(y) {
  if (!(x_.hi > x_.lo)) x_ = padded(x_.lo, x_.hi);
  if (!(y_.hi > y_.lo)) y_ = padded(y_.lo, y_.hi);
}

double Panel::px(double x) const { return left_ + (x - x_.lo) / (x_.hi - x_.lo) * width_; }
double Panel::py(double y) const { return top_ + height_ - (y - y_.lo) / (y_.hi - y_.lo) * height_; }

void Panel::labels(std::string xlabel, std::string ylabel, std::string title) {
  xlabel_ = std::move(xlabel);
  ylabel_ = std::move(ylabel);
  title_ = std::move(title);
}

void Panel::band(const std::vector<double>& x, const std::vector<double>& lo, const std::vector<double>& hi,
                 const std::string& color, double opacity, const std::string& legend) {
  const std::size_t n = std::min({x.size(), lo.size(), hi.size()});
  if (n < 2) return;
  std::string d;
  for (std::size_t i = 0; i < n; ++i) d += fmt::format("{}{} {}", i ? "L" : "M", num(px(x[i])), num(py(hi[i])));
  for (std::size_t i = n; i-- > 0;) d += fmt::format("L{} {}", num(px(x[i])), num(py(lo[i])));
  body_ += fmt::format("<path d=\"{}Z\" fill=\"{}\" fill-opacity=\"{}\" stroke=\"none\"/>\n", d, color, opacity);
  if (!legend.empty()) legend_.push_back({"band", color, "", legend, opacity, Marker::Circle});
}

void Panel::line(const std::vector<double>& x, const std::vector<double>& y, const std::string& color, double width,
                 const std::string& dash, const std::string& legend) {
  const std::size_t n = std::min(x.size(), y.size());
  if (n < 2) return;
  std::string d;
  bool pen_down = false;
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(y[i])) {
      pen_down = false;
      continue;
    }
    d += fmt::format("{}{} {}", pen_down ? "L" : "M", num(px(x[i])), num(py(y[i])));
    pen_down = true;
  }
  body_ += fmt::format("<path d=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"{}\"{}/>\n", d, color, width,
                       dash.empty() ? std::string() : fmt::format(" stroke-dasharray=\"{}\"", dash));
  if (!legend.empty()) legend_.push_back({"line", color, dash, legend, 1.0, Marker::Circle});
}

void Panel::markers(const std::vector<double>& x, const std::vector<double>& y, Marker shape, const std::string& color,
                    double size, const std::string& css_class, const std::string& legend) {
  const std::size_t n = std::min(x.size(), y.size());
  for (std::size_t i = 0; i < n; ++i)
    if (std::isfinite(x[i]) && std::isfinite(y[i])) body_ += marker_svg(shape, px(x[i]), py(y[i]), size, color, css_class);
  if (!legend.empty()) legend_.push_back({"marker", color, "", legend, 1.0, shape});
}

void Panel::vline(double x, const std::string& color, const std::string& dash, const std::string& legend) {
  if (!std::isfinite(x)) return;
  body_ += fmt::format("<line x1=\"{0}\" y1=\"{1}\" x2=\"{0}\" y2=\"{2}\" stroke=\"{3}\" stroke-width=\"1.6\"{4}/>\n",
                       num(px(x)), num(top_), num(top_ + height_), color,
                       dash.empty() ? std::string() : fmt::format(" stroke-dasharray=\"{}\"", dash));
  if (!legend.empty()) legend_.push_back({"line", color, dash, legend, 1.0, Marker::Circle});
}

void Panel::heatmap(const Mat& z, const std::string& zlabel) {
  if (z.size() == 0) return;
  double zlo = std::numeric_limits<double>::infinity(), zhi = -zlo;
  for (Index i = 0; i < z.size(); ++i)
    if (std::isfinite(z.data()[i])) {
      zlo = std::min(zlo, z.data()[i]);
      zhi = std::max(zhi, z.data()[i]);
    }
  if (!std::isfinite(zlo)) return;
  if (!(zhi > zlo)) zhi = zlo + 1e-12;
  const double cw = width_ / static_cast<double>(z.cols()), ch = height_ / static_cast<double>(z.rows());
  std::string cells = "<g shape-rendering=\"crispEdges\">\n";
  for (Index i = 0; i < z.rows(); ++i)
    for (Index j = 0; j < z.cols(); ++j) {
      if (!std::isfinite(z(i, j))) continue;
      // Row i is at the i-th y from the bottom; cells overlap by a hair to hide seams in viewers.
      cells += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"{}\"/>\n",
                           num(left_ + static_cast<double>(j) * cw), num(top_ + height_ - static_cast<double>(i + 1) * ch),
                           num(cw + 0.4), num(ch + 0.4), colormap((z(i, j) - zlo) / (zhi - zlo)));
    }
  body_ = cells + "</g>\n" + body_;
  // Colour bar right of the panel.
  const double bx = left_ + width_ + 12, bw = 14;
  std::string bar;
  const int steps = 64;
  for (int k = 0; k < steps; ++k) {
    const double y0 = top_ + height_ * (1.0 - static_cast<double>(k + 1) / steps);
    bar += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"{}\" shape-rendering=\"crispEdges\"/>\n",
                       num(bx), num(y0), num(bw), num(height_ / steps + 0.4), colormap((k + 0.5) / steps));
  }
  bar += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"black\"/>\n", num(bx),
                     num(top_), num(bw), num(height_));
  const std::vector<double> ticks = nice_ticks(zlo, zhi, 5);
  const double step = ticks.size() > 1 ? ticks[1] - ticks[0] : (zhi - zlo);
  for (double t : ticks) {
    const double y = top_ + height_ - (t - zlo) / (zhi - zlo) * height_;
    bar += fmt::format("<line x1=\"{0}\" y1=\"{1}\" x2=\"{2}\" y2=\"{1}\" stroke=\"black\"/>\n", num(bx + bw),
                       num(y), num(bx + bw + 4));
    bar += fmt::format("<text x=\"{}\" y=\"{}\" font-size=\"11\" {} dominant-baseline=\"middle\">{}</text>\n",
                       num(bx + bw + 6), num(y), kFont, escape(tick_label(t, step)));
  }
  bar += fmt::format("<text x=\"{0}\" y=\"{1}\" font-size=\"12\" {2} text-anchor=\"middle\" "
                     "transform=\"rotate(90 {0} {1})\">{3}</text>\n",
                     num(bx + bw + 56), num(top_ + height_ / 2), kFont, escape(zlabel));
  colorbar_ = bar;
}

std::string Panel::render() const {
  std::string s = fmt::format("<g id=\"panel{}\">\n", id_);
  s += fmt::format("<clipPath id=\"clip{}\"><rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\"/></clipPath>\n", id_,
                   num(left_), num(top_), num(width_), num(height_));
  s += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"white\"/>\n", num(left_), num(top_),
                   num(width_), num(height_));
  // Grid and ticks.
  const std::vector<double> xt = nice_ticks(x_.lo, x_.hi, 6), yt = nice_ticks(y_.lo, y_.hi, 6);
  const double xstep = xt.size() > 1 ? xt[1] - xt[0] : (x_.hi - x_.lo);
  const double ystep = yt.size() > 1 ? yt[1] - yt[0] : (y_.hi - y_.lo);
  for (double t : xt)
    s += fmt::format("<line x1=\"{0}\" y1=\"{1}\" x2=\"{0}\" y2=\"{2}\" stroke=\"#e5e5e5\"/>\n", num(px(t)), num(top_),
                     num(top_ + height_));
  for (double t : yt)
    s += fmt::format("<line x1=\"{1}\" y1=\"{0}\" x2=\"{2}\" y2=\"{0}\" stroke=\"#e5e5e5\"/>\n", num(py(t)),
                     num(left_), num(left_ + width_));
  s += fmt::format("<g clip-path=\"url(#clip{})\">\n{}</g>\n", id_, body_);
  s += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"black\"/>\n", num(left_),
                   num(top_), num(width_), num(height_));
  for (double t : xt) {
    s += fmt::format("<line x1=\"{0}\" y1=\"{1}\" x2=\"{0}\" y2=\"{2}\" stroke=\"black\"/>\n", num(px(t)),
                     num(top_ + height_), num(top_ + height_ + 5));
    s += fmt::format("<text x=\"{}\" y=\"{}\" font-size=\"11\" {} text-anchor=\"middle\">{}</text>\n", num(px(t)),
                     num(top_ + height_ + 17), kFont, escape(tick_label(t, xstep)));
  }
  for (double t : yt) {
    s += fmt::format("<line x1=\"{0}\" y1=\"{1}\" x2=\"{2}\" y2=\"{1}\" stroke=\"black\"/>\n", num(left_ - 5), num(py(t)),
                     num(left_));
    s += fmt::format("<text x=\"{}\" y=\"{}\" font-size=\"11\" {} text-anchor=\"end\" dominant-baseline=\"middle\">{}"
                     "</text>\n",
                     num(left_ - 8), num(py(t)), kFont, escape(tick_label(t, ystep)));
  }
  if (!xlabel_.empty())
    s += fmt::format("<text x=\"{}\" y=\"{}\" font-size=\"13\" {} text-anchor=\"middle\">{}</text>\n",
                     num(left_ + width_ / 2), num(top_ + height_ + 36), kFont, escape(xlabel_));
  if (!ylabel_.empty())
    s += fmt::format("<text x=\"{0}\" y=\"{1}\" font-size=\"13\" {2} text-anchor=\"middle\" "
                     "transform=\"rotate(-90 {0} {1})\">{3}</text>\n",
                     num(left_ - 52), num(top_ + height_ / 2), kFont, escape(ylabel_));
  if (!title_.empty())
    s += fmt::format("<text x=\"{}\" y=\"{}\" font-size=\"14\" font-weight=\"bold\" {} text-anchor=\"middle\">{}</text>\n",
                     num(left_ + width_ / 2), num(top_ - 10), kFont, escape(title_));
  s += colorbar_;
  if (!legend_.empty()) {
    std::size_t longest = 0;
    for (const auto& e : legend_) longest = std::max(longest, e.label.size());
    const double lw = 38 + 6.6 * static_cast<double>(longest), lh = 8 + 18.0 * static_cast<double>(legend_.size());
    double lx = left_ + width_ - lw - 8, ly = top_ + 8;
    if (legend_place_ == LegendPlace::Right) {
      lx = left_ + width_ + 14;
      ly = top_;
    } else if (legend_place_ == LegendPlace::Below) {
      lx = left_;
      ly = top_ + height_ + 48;
    }
    s += fmt::format("<g class=\"legend\"><rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"white\" "
                     "fill-opacity=\"0.9\" stroke=\"#999\"/>\n",
                     num(lx), num(ly), num(lw), num(lh));
    for (std::size_t k = 0; k < legend_.size(); ++k) {
      const Entry& e = legend_[k];
      const double cy = ly + 13 + 18.0 * static_cast<double>(k), sx = lx + 8;
      if (e.kind == "band") {
        s += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"22\" height=\"10\" fill=\"{}\" fill-opacity=\"{}\"/>\n",
                         num(sx), num(cy - 5), e.color, e.opacity);
      } else if (e.kind == "line") {
        s += fmt::format("<line x1=\"{0}\" y1=\"{2}\" x2=\"{1}\" y2=\"{2}\" stroke=\"{3}\" stroke-width=\"2\"{4}/>\n",
                         num(sx), num(sx + 22), num(cy), e.color,
                         e.dash.empty() ? std::string() : fmt::format(" stroke-dasharray=\"{}\"", e.dash));
      } else {
        s += marker_svg(e.shape, sx + 11, cy, 4.5, e.color, "");
      }
      s += fmt::format("<text x=\"{}\" y=\"{}\" font-size=\"11\" {} dominant-baseline=\"middle\">{}</text>\n",
                       num(sx + 28), num(cy), kFont, escape(e.label));
    }
    s += "</g>\n";
  }
  return s + "</g>\n";
}

// ---- Figure ----
Figure::Figure(double width, double height, std::string title) : width_(width), height_(height), title_(std::move(title)) {}

Panel& Figure::panel(double left, double top, double width, double height, Range x, Range y) {
  panels_.emplace_back(static_cast<int>(panels_.size()), left, top, width, height, x, y);
  return panels_.back();
}

std::string Figure::render() const {
  std::string s = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"{0}\" height=\"{1}\" viewBox=\"0 0 {0} {1}\">\n",
      num(width_), num(height_));
  s += fmt::format("<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n");
  if (!title_.empty())
    s += fmt::format("<text x=\"{}\" y=\"22\" font-size=\"15\" font-weight=\"bold\" {} text-anchor=\"middle\">{}</text>\n",
                     num(width_ / 2), kFont, escape(title_));
  for (const auto& p : panels_) s += p.render();
  return s + "</svg>\n";
}

}  // namespace varbo::svg
