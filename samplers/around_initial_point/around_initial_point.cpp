#include "around_initial_point.hpp"

#include <fmt/format.h>

#include <cmath>

#include "varbo/errors.hpp"

namespace varbo::sampling {

double single_point_radius_se(double lengthscale, double gamma) {
  if (!(gamma > 0 && gamma < 1)) throw ConfigError(fmt::format("around_initial_point: gamma must be in (0, 1), got {}", gamma));
  return lengthscale * std::sqrt(-std::log1p(-gamma * gamma));
}

AroundInitialPointSampler::AroundInitialPointSampler(AroundInitialPointOptions options, std::optional<Vec> center)
    : options_(options), center_(std::move(center)) {
  if (options_.radius < 0) (void)single_point_radius_se(options_.lengthscale, options_.gamma);  // validates γ
}

double AroundInitialPointSampler::radius() const {
  return options_.radius >= 0 ? options_.radius : single_point_radius_se(options_.lengthscale, options_.gamma);
}

Mat AroundInitialPointSampler::sample(const RegionConstraint& region, Index n, Rng& rng) const {
  const Box& box = region.bounds();
  const Index d = box.dim();
  if (n <= 0) return Mat(0, d);
  Vec c = center_ ? *center_ : Vec(0.5 * (box.lower + box.upper));
  if (c.size() != d)
    throw InputError(fmt::format("around_initial_point: initial point has dimension {}, the region {}", c.size(), d));
  c = box.clamp(c);
  const double r0 = radius();
  // A random orthonormal basis (QR of a Gaussian matrix) spreads the first d points evenly in direction.
  Mat G(d, d);
  for (Index j = 0; j < d; ++j) G.col(j) = rng.normal_vec(d);
  const Mat Q = Eigen::HouseholderQR<Mat>(G).householderQ();
  Mat out(n, d);
  out.row(0) = c.transpose();
  for (Index k = 1; k < n; ++k) {
    const Index j = k - 1;
    Vec u;
    if (j < d) {
      u = Q.col(j);
    } else if (j < 2 * d) {
      u = -Q.col(j - d);
    } else {
      u = rng.normal_vec(d);
      u /= std::max(u.norm(), 1e-300);
    }
    Vec x = box.clamp(c + r0 * u);
    // θ0 on a bound or in a corner: a direction pointing out of the box was clamped back onto θ0 itself, and θ0
    // ran twice (a fall, twice, when it is a bad policy; red team, session 30). The opposite direction instead.
    if ((x - c).lpNorm<Eigen::Infinity>() <= 1e-12) x = box.clamp(c - r0 * u);
    out.row(k) = x.transpose();
  }
  return out;
}

}  // namespace varbo::sampling
