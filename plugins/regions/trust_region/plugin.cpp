// Plugin `region_trust_region`: TuRBO-1's trust region (Eriksson et al. 2019) as a box region.
#include <fmt/format.h>

#include "trust_region.hpp"
#include "varbo/errors.hpp"
#include "varbo/option_set.hpp"
#include "varbo/plugin.hpp"

namespace {
using varbo::TrustRegionOptions;
namespace opt = varbo::opt;
const varbo::OptionSet<TrustRegionOptions>& trust_region_options() {
  static const varbo::OptionSet<TrustRegionOptions> set{
      opt::real("length_init", &TrustRegionOptions::length_init, "initial side length L (unit cube)").above(0),
      opt::real("length_min", &TrustRegionOptions::length_min, "restart when L falls below this (0.5^7)").above(0),
      opt::real("length_max", &TrustRegionOptions::length_max, "largest side length").above(0),
      opt::integer("success_tolerance", &TrustRegionOptions::success_tolerance, "consecutive successes that double L")
          .at_least(1),
      opt::integer("failure_tolerance", &TrustRegionOptions::failure_tolerance,
                   "consecutive failures that halve L; 0 = ceil(max(4/q, d/q))")
          .at_least(0),
      opt::integer("batch_size", &TrustRegionOptions::batch_size, "q, for the default failure tolerance").at_least(1),
      opt::real("improvement", &TrustRegionOptions::improvement,
                "a success improves the best cost by more than this fraction of |best|")
          .at_least(0),
      opt::real("restart_length", &TrustRegionOptions::restart_length,
                "with restart_center: incumbent, L after a restart (the box re-centres on the incumbent, so a value "
                "≥ 2, the whole unit cube, makes the search after a collapse global)")
          .above(0),
      opt::choice("restart_center", &TrustRegionOptions::restart_center, {"incumbent", "new_points"},
                  "after a restart: new_points = TuRBO's fresh start (bo draws a new design, models the points "
                  "since the restart, and refines the incumbent of all the data in its last trials); incumbent = the "
                  "box re-centres on the incumbent of all the data with L = restart_length, the model keeps every "
                  "observation"),
      opt::real("stall_distance", &TrustRegionOptions::stall_distance,
                "a failure whose new point lies within this distance (∞-norm, unit cube) of the incumbent is a stall")
          .at_least(0),
      opt::integer("stall_tolerance", &TrustRegionOptions::stall_tolerance,
                   "consecutive stalls that restart the region at once (converged); 0 = failure_tolerance, -1 = off")
          .at_least(-1),
      opt::choice("stall_count", &TrustRegionOptions::stall_count, {"consecutive", "since_success"},
                  "which stalls count toward stall_tolerance: those in a row (a failure away from the incumbent "
                  "resets the count), or all since the last success")};
  return set;
}
}  // namespace

VARBO_PLUGIN("region_trust_region", "0.1.0", "TuRBO-1 trust region: a box around the incumbent that grows and shrinks") {
  using namespace varbo;
  registry.add(make_component<RegionConstraint>(
      "trust_region",
      "Box of side L around the best observed point; L doubles after success_tolerance successes, halves after "
      "failure_tolerance failures, restarts when below length_min (Eriksson 2019, TuRBO-1), or after "
      "stall_tolerance trials next to the incumbent without improvement; a restart starts afresh (restart_center: "
      "new_points): a new design and a model of the new points, bo's last trials "
      "refining the incumbent of all the data; or (restart_center: incumbent) keeps the data and the incumbent",
      trust_region_options().specs(),
      [](const Options& o, const BuildContext& ctx) -> std::unique_ptr<RegionConstraint> {
        if (ctx.dim <= 0) throw ConfigError("region 'trust_region' needs the problem dimension (got 0)");
        const TrustRegionOptions t = trust_region_options().read(o);
        // Checked here, where the keys are known, so the error names file:line:col (the constructor's own check
        // cannot say where the numbers came from).
        if (!(t.length_min <= t.length_init && t.length_init <= t.length_max))
          // The key the user gave (length_init: 5 blamed length_max, which was the default; session 30).
          o.node(o.given("length_init") && !o.given("length_min") && !o.given("length_max") ? "length_init"
                 : t.length_min > t.length_init                                             ? "length_min"
                                                                                            : "length_max")
              .fail(fmt::format("need length_min <= length_init <= length_max, got {}, {}, {}", t.length_min,
                                t.length_init, t.length_max));
        return std::make_unique<TrustRegion>(ctx.dim, t);
      }));
}
