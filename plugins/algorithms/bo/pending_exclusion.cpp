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

double AwayFromPoints::evaluate(const Vec& x, Vec* grad) const {
  for (const Vec& c : points_) {
    const Vec v = x - c;
    Index j = 0;
    const double d = v.cwiseAbs().maxCoeff(&j);
    if (d < radius_) {
      // Below every value outside (floor − 1 at the face), lowest at the centre; the gradient points outwards
      // along the coordinate that sets the ∞-norm.
      if (grad) {
        *grad = Vec::Zero(x.size());
        (*grad)(j) = (v(j) >= 0 ? 1.0 : -1.0) / radius_;
      }
      return floor_ - 1.0 - (radius_ - d) / radius_;
    }
  }
  return inner_.evaluate(x, grad);
}

std::string AwayFromPoints::state() const {
  return fmt::format("{} | away from {} pending point(s) by {:g}", inner_.state(), points_.size(), radius_);
}

}  // namespace varbo::bo
