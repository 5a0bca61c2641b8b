// libvarbo_region_box.so: the unit-cube region.
#include "unit_box_region.hpp"
#include "varbo/plugin.hpp"

VARBO_PLUGIN("region_box", "0.1.0", "The whole unit cube as the acquisition search region") {
  registry.add(varbo::make_component<varbo::RegionConstraint>(
      "box", "the whole domain (unit cube); the evaluated points seed the acquisition search", {},
      varbo::Factory<varbo::RegionConstraint>([](const varbo::Options&, const varbo::BuildContext& ctx) {
        return std::make_unique<varbo::regions::UnitBoxRegion>(ctx.dim);
      })));
}
