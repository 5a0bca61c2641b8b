#include "pending_exclusion.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include <fmt/format.h>

namespace varbo::bo {

Index nearest_within(const Vec& x, const std::vector<Vec>& points, double radius) {
  for (std::size_t i = 0; i < points.size(); ++i)
    if (points[i].size() == x.size() && (x - points[i]).lpNorm<Eigen::Infinity>() <= radius)
      return static_cast<Index>(i);
  return -1;
}

AwayFromPoints::AwayFromPoints(const Acquisition& inner, std::vector<Vec> points, double radius, double floor)
    : inner_(inner), points_(std::move(points)), radius_(radius), floor_(floor) {}

double AwayFromPoints::below_values(const Acquisition& inner, const Mat& X) {
  double u = 0;
  for (Index i = 0; i < X.rows(); ++i) {
    const double v = inner.evaluate(X.row(i).transpose(), nullptr);
    if (std::isfinite(v)) u = std::min(u, v);
  }
  return u;
}

std::optional<double> excluded_ball_value(const Vec& x, const std::vector<Vec>& centres, double radius, double floor,
                                          Vec* grad) {
  for (const Vec& c : centres) {
    const Vec v = x - c;
    Index j = 0;
    const double d = v.cwiseAbs().maxCoeff(&j);
    if (d < radius) {
      if (grad) {
        *grad = Vec::Zero(x.size());
        (*grad)(j) = (v(j) >= 0 ? 1.0 : -1.0) / radius;
      }
      return floor - 1.0 - (radius - d) / radius;
    }
  }
  return std::nullopt;
}

double AwayFromPoints::evaluate(const Vec& x, Vec* grad) const {
  // Below every value outside (floor − 1 at a ball's face), so a local maximizer started inside climbs out.
  if (const std::optional<double> v = excluded_ball_value(x, points_, radius_, floor_, grad)) return *v;
  return inner_.evaluate(x, grad);
}

std::string AwayFromPoints::state() const {
  return fmt::format("{} | away from {} pending point(s) by {:g}", inner_.state(), points_.size(), radius_);
}

}  // namespace varbo::bo
