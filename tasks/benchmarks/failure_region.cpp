#include "failure_region.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <vector>

#include "varbo/option_set.hpp"

namespace varbo::tasks {

bool FailureRegion::contains(const Vec& u) const {
  if (shape == Shape::Ball) return (u - center).norm() < radius;
  // Closed: a box reaching the domain's faces (a slab lower: [0, …, 0.7], upper: [1, …, 1]) holds the points on
  // them, where acquisition optimizers clamp many trials; with strict bounds a point with any coordinate at 0
  // or 1 escaped the slab.
  return (u.array() >= lower.array()).all() && (u.array() <= upper.array()).all();
}

std::string FailureRegion::describe() const {
  auto v = [](const Vec& x) { return fmt::format("[{}]", fmt::join(x.data(), x.data() + x.size(), ", ")); };
  if (shape == Shape::Ball) return fmt::format("ball centre {} radius {} (box fractions)", v(center), radius);
  return fmt::format("box {} to {} (box fractions)", v(lower), v(upper));
}

namespace {
// The corners and the centre are vectors of the problem's dimension: read by hand below.
const OptionSet<FailureRegion>& failure_region_option_set() {
  using Shape = FailureRegion::Shape;
  static const OptionSet<FailureRegion> set{
      opt::choice("shape", &FailureRegion::shape, {{"ball", Shape::Ball}, {"box", Shape::Box}},
                  "ball: |u − center| < radius; box: lower ≤ u ≤ upper (closed)"),
      opt::reals("center", "", "ball centre, one fraction of the box per dimension"),
      opt::real("radius", &FailureRegion::radius, "ball radius in box fractions (Euclidean)").at_least(0),
      opt::reals("lower", "", "box: lower corner, one fraction per dimension"),
      opt::reals("upper", "", "box: upper corner, one fraction per dimension"),
  };
  return set;
}
}  // namespace

std::vector<OptionSpec> failure_region_options() { return failure_region_option_set().specs(); }

std::optional<FailureRegion> parse_failure_region(const Options& o, Index dim) {
  if (!o.is_set("failure_region")) return std::nullopt;
  const ConfigNode node = o.node("failure_region");
  if (!node.is_map()) node.fail("expected a map: {shape: ball, center: [...], radius: r} or {shape: box, lower: [...], upper: [...]}");
  const Options fo = validate_options(node, failure_region_option_set().specs(), "failure_region", nullptr, {});
  auto vec = [&](const char* key) {
    if (!fo.is_set(key)) node.fail(fmt::format("failure_region of shape {} needs '{}'", fo.str("shape"), key));
    const std::vector<double> v = fo.reals(key);
    if (static_cast<Index>(v.size()) != dim)
      fo.node(key).fail(fmt::format("expected {} values (one per dimension), got {}", dim, v.size()));
    return Vec(Eigen::Map<const Vec>(v.data(), dim));
  };
  FailureRegion r = failure_region_option_set().read(fo);
  // The other shape's keys were ignored in silence (a ball given lower/upper ran as the default ball; red team,
  // session 26).
  for (const char* key : r.shape == FailureRegion::Shape::Ball ? std::vector<const char*>{"lower", "upper"}
                                                               : std::vector<const char*>{"center", "radius"})
    if (fo.given(key))
      fo.node(key).fail(fmt::format("'{}' belongs to the other shape; a {} takes {}", key, fo.str("shape"),
                                    r.shape == FailureRegion::Shape::Ball ? "center and radius" : "lower and upper"));
  if (r.shape == FailureRegion::Shape::Ball) {
    r.center = vec("center");
    if (!(r.radius > 0)) node.fail("failure_region: a ball needs radius > 0");
  } else {
    r.lower = vec("lower");
    r.upper = vec("upper");
    if (!(r.lower.array() < r.upper.array()).all()) fo.node("upper").fail("expected upper > lower in every dimension");
  }
  return r;
}

}  // namespace varbo::tasks
