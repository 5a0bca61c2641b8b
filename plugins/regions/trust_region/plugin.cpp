// Plugin `region_trust_region`: TuRBO-1's trust region (Eriksson et al. 2019) as a box region.
#include "trust_region.hpp"
#include "varbo/errors.hpp"
#include "varbo/plugin.hpp"

VARBO_PLUGIN("region_trust_region", "0.1.0", "TuRBO-1 trust region: a box around the incumbent that grows and shrinks") {
  using namespace varbo;
  registry.add(make_component<RegionConstraint>(
      "trust_region",
      "Box of side L around the best observed point; L doubles after success_tolerance successes, halves after "
      "failure_tolerance failures, resets when below length_min (Eriksson 2019, TuRBO-1); data are kept on restart",
      {opt::real("length_init", 0.8, "initial side length L (unit cube)").above(0),
       opt::real("length_min", 0.0078125, "restart when L falls below this (0.5^7)").above(0),
       opt::real("length_max", 1.6, "largest side length").above(0),
       opt::integer("success_tolerance", 3, "consecutive successes that double L").at_least(1),
       opt::integer("failure_tolerance", 0, "consecutive failures that halve L; 0 = ceil(max(4/q, d/q))").at_least(0),
       opt::integer("batch_size", 1, "q, for the default failure tolerance").at_least(1),
       opt::real("improvement", 1e-3, "a success improves the best cost by more than this fraction of |best|")
           .at_least(0),
       opt::real("restart_length", 0.8,
                 "L after a restart; the data are kept and the box re-centres on the incumbent, so a value ≥ 2 "
                 "(the whole unit cube) makes the search after a collapse global")
           .above(0)},
      [](const Options& o, const BuildContext& ctx) -> std::unique_ptr<RegionConstraint> {
        if (ctx.dim <= 0) throw ConfigError("region 'trust_region' needs the problem dimension (got 0)");
        TrustRegionOptions t;
        t.length_init = o.real("length_init");
        t.length_min = o.real("length_min");
        t.length_max = o.real("length_max");
        t.success_tolerance = static_cast<int>(o.integer("success_tolerance"));
        t.failure_tolerance = static_cast<int>(o.integer("failure_tolerance"));
        t.batch_size = static_cast<int>(o.integer("batch_size"));
        t.improvement = o.real("improvement");
        t.restart_length = o.real("restart_length");
        return std::make_unique<TrustRegion>(ctx.dim, t);
      }));
}
