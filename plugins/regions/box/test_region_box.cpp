// The box region: the unit cube, with the data as seeds.
#include "unit_box_region.hpp"
#include "varbo/errors.hpp"
#include "varbo_test.hpp"

using namespace varbo;

TEST_CASE("box region: unit cube bounds, no constraint, data as seeds") {
  regions::UnitBoxRegion region(3);
  CHECK(region.bounds().lower == Vec::Zero(3));
  CHECK(region.bounds().upper == Vec::Ones(3));
  CHECK_FALSE(region.has_constraint());
  CHECK(region.seeds().rows() == 0);
  CHECK(region.contains(Vec{{0.0, 0.5, 1.0}}));
  CHECK_FALSE(region.contains(Vec{{0.0, 0.5, 1.1}}));
  Dataset data = Dataset::empty(3);
  data.add(Vec{{0.1, 0.2, 0.3}}, 1.0);
  data.add(Vec{{0.9, 0.8, 0.7}}, 2.0);
  Rng rng(1);
  region.update(nullptr, data, rng);
  CHECK(region.seeds() == data.X);
  data.add(Vec{{0.5, 0.5, 0.5}}, 0.0);
  region.update(nullptr, data, rng);
  CHECK(region.seeds().rows() == 3);
  CHECK_FALSE(region.state().empty());
  CHECK_THROWS_AS(region.update(nullptr, Dataset{Mat::Zero(1, 2), Vec::Zero(1)}, rng), InputError);
  CHECK_THROWS_AS(regions::UnitBoxRegion(0), ConfigError);
}

TEST_CASE("the plugin registers the box region, sized by the build context") {
  BuildContext ctx;
  ctx.dim = 4;
  auto region = test::registry().create<RegionConstraint>("box", ctx);
  CHECK(region->bounds().dim() == 4);
}
