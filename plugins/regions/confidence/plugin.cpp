// Plugin `region_confidence`: the confidence region of cautious BO (Fröhlich et al. 2021, eq. 3).
#include <fmt/format.h>

#include "confidence_region.hpp"
#include "varbo/errors.hpp"
#include "varbo/plugin.hpp"

VARBO_PLUGIN("region_confidence", "0.1.0", "Confidence region sigma_n <= gamma*sigma_f of cautious BO (CRBO)") {
  using namespace varbo;
  registry.add(make_component<RegionConstraint>(
      "confidence",
      "C_n = {theta : sigma_n(theta) <= gamma*sigma_f} on the latent predictive variance (Froehlich 2021, eq. 3); "
      "widened by x1.2 of the variance scale (up to 50 times) when only the data satisfy it",
      {opt::real("gamma", 0.6, "confidence parameter gamma; smaller = more cautious").above(0).below(1),
       opt::real("probe_radius", 0.01, "distance (unit cube) of the random probes around the data that decide "
                                       "whether the region holds more than the data").above(0).at_most(1),
       opt::integer("max_widenings", 50, "at most this many x1.2 widenings of the variance scale").at_least(0),
       opt::boolean("report", true, "log the cautiousness report (r0, Lipschitz estimate, worst-case next cost; "
                                    "Froehlich 2021 sec. 4.1) in state() after each update"),
       opt::choice("report_kernel", "matern52", {"matern52", "se"},
                   "kernel assumed for the report's single-point radius r0 (the surrogate's kernel)")},
      [](const Options& o, const BuildContext& ctx) -> std::unique_ptr<RegionConstraint> {
        if (ctx.dim <= 0) throw ConfigError("region 'confidence' needs the problem dimension (got 0)");
        ConfidenceRegionOptions opts;
        opts.gamma = o.real("gamma");
        opts.probe_radius = o.real("probe_radius");
        opts.max_widenings = static_cast<int>(o.integer("max_widenings"));
        opts.report = o.boolean("report");
        opts.report_kernel = o.str("report_kernel") == "se" ? ReportKernel::SquaredExponential : ReportKernel::Matern52;
        return std::make_unique<ConfidenceRegion>(ctx.dim, opts);
      },
      {"region:constraint"}, {"optimizer:constraints"}));
}
