#pragma once
// A small SVG writer for model pictures (`varbo plot`): panels with axes, ticks, labels, lines, ±bands,
// markers, vertical rules, heat maps with a colour bar, and a legend. Plain text output, no dependencies.
#include <deque>
#include <string>
#include <vector>

#include "varbo/types.hpp"

namespace varbo::svg {

struct Range {
  double lo = 0, hi = 1;
};

/// About `target` round tick values (1, 2, 5 × 10^k steps) inside [lo, hi].
std::vector<double> nice_ticks(double lo, double hi, int target = 6);
/// [lo, hi] widened by `pad` of its width on both sides (a zero width becomes ±0.5 or ±|lo|/2).
Range padded(double lo, double hi, double pad = 0.05);
/// The viridis-like colour of t ∈ [0, 1] as "#rrggbb" (perceptually ordered, colour-blind safe).
std::string colormap(double t);
/// Escapes &, <, >, " for text and attributes.
std::string escape(const std::string& text);

enum class Marker { Circle, Cross, Diamond, Triangle };

/// One plotting area. Coordinates of every call are data units; drawing is clipped to the area.
class Panel {
 public:
  Panel(int id, double left, double top, double width, double height, Range x, Range y);
  void labels(std::string xlabel, std::string ylabel, std::string title);
  void band(const std::vector<double>& x, const std::vector<double>& lo, const std::vector<double>& hi,
            const std::string& color, double opacity, const std::string& legend = "");
  void line(const std::vector<double>& x, const std::vector<double>& y, const std::string& color, double width,
            const std::string& dash = "", const std::string& legend = "");
  /// Each marker carries class="<css_class>" so a reader (or a test) can count them.
  void markers(const std::vector<double>& x, const std::vector<double>& y, Marker shape, const std::string& color,
               double size, const std::string& css_class, const std::string& legend = "");
  void vline(double x, const std::string& color, const std::string& dash, const std::string& legend = "");
  /// z(i, j) is the value at y = ys(i), x = xs(j) on a regular grid covering the panel's ranges; a colour bar
  /// right of the panel shows `zlabel`. Non-finite cells are left blank.
  void heatmap(const Mat& z, const std::string& zlabel);
  enum class LegendPlace { Inside, Right, Below };
  /// Legend inside the panel's top-right corner (default), to the right of it, or below its x label.
  void legend_place(LegendPlace place) { legend_place_ = place; }
  std::string render() const;

 private:
  double px(double x) const;
  double py(double y) const;
  struct Entry {
    std::string kind, color, dash, label;
    double opacity = 1;
    Marker shape = Marker::Circle;
  };
  int id_;
  double left_, top_, width_, height_;
  Range x_, y_;
  std::string xlabel_, ylabel_, title_;
  std::string body_, colorbar_;
  std::vector<Entry> legend_;
  LegendPlace legend_place_ = LegendPlace::Inside;
};

class Figure {
 public:
  Figure(double width, double height, std::string title = "");
  /// Adds a panel at (left, top) of size width × height, in pixels.
  Panel& panel(double left, double top, double width, double height, Range x, Range y);
  std::string render() const;

 private:
  double width_, height_;
  std::string title_;
  std::deque<Panel> panels_;  // deque: panel() hands out references that must stay valid
};

}  // namespace varbo::svg
