// libvarbo_sampler_around_initial_point.so: CRBO's initial design, θ0 plus points at distance r0 around it.
#include <fmt/format.h>

#include "around_initial_point.hpp"
#include "varbo/option_set.hpp"
#include "varbo/plugin.hpp"

namespace {
using varbo::sampling::AroundInitialPointOptions;
namespace opt = varbo::opt;
const varbo::OptionSet<AroundInitialPointOptions>& around_options() {
  static const varbo::OptionSet<AroundInitialPointOptions> set{
      opt::real("lengthscale", &AroundInitialPointOptions::lengthscale, "lengthscale l (unit cube) defining r0").above(0),
      opt::real("gamma", &AroundInitialPointOptions::gamma, "confidence parameter gamma defining r0").above(0).below(1),
      opt::real("radius", &AroundInitialPointOptions::radius,
                "explicit radius r0 (unit cube); -1: from lengthscale and gamma")
          .at_least(-1)};
  return set;
}
}  // namespace

VARBO_PLUGIN("sampler_around_initial_point", "0.1.0", "Initial design theta0 plus points on a sphere of radius r0 around it") {
  using namespace varbo;
  registry.add(make_component<Sampler>(
      "around_initial_point",
      "row 0: the initial point theta0 (study initial_point / task, else the box centre); further rows at "
      "distance r0 = lengthscale*sqrt(-log(1-gamma^2)) around it (orthogonal random directions), clipped into "
      "the box. CRBO (crbo.md) uses bo initial_points = ceil(sqrt(d))",
      around_options().specs(),
      Factory<Sampler>([](const Options& o, const BuildContext& ctx) {
        const double radius = o.real("radius");
        if (radius < 0 && radius != -1)
          // Any value in (-1, 0) meant "from lengthscale and gamma" in silence.
          o.node("radius").fail(fmt::format("expected a radius ≥ 0 (unit cube), or -1 for r0 from lengthscale and "
                                            "gamma; got {}",
                                            radius));
        return std::make_unique<sampling::AroundInitialPointSampler>(around_options().read(o), ctx.initial_point);
      })));
}
