// Plugin `region_confidence`: the confidence region of cautious BO (Fröhlich et al. 2021, eq. 3).
#include <fmt/format.h>

#include "confidence_region.hpp"
#include "varbo/errors.hpp"
#include "varbo/option_set.hpp"
#include "varbo/plugin.hpp"

namespace {
using varbo::ConfidenceRegionOptions;
namespace opt = varbo::opt;
const varbo::OptionSet<ConfidenceRegionOptions>& confidence_options() {
  static const varbo::OptionSet<ConfidenceRegionOptions> set{
      opt::real("gamma", &ConfidenceRegionOptions::gamma, "confidence parameter gamma; smaller = more cautious")
          .above(0)
          .below(1),
      opt::real("probe_radius", &ConfidenceRegionOptions::probe_radius,
                "distance (unit cube) of the random probes around the data that decide "
                "whether the region holds more than the data")
          .above(0)
          .at_most(1),
      opt::integer("max_widenings", &ConfidenceRegionOptions::max_widenings,
                   "at most this many x1.2 widenings of the variance scale")
          .at_least(0),
      opt::boolean("report", &ConfidenceRegionOptions::report,
                   "log the cautiousness report (r0, Lipschitz estimate, worst-case next cost; "
                   "Froehlich 2021 sec. 4.1) in state() after each update"),
      opt::choice("report_kernel", &ConfidenceRegionOptions::report_kernel,
                  {{"matern52", varbo::ReportKernel::Matern52}, {"se", varbo::ReportKernel::SquaredExponential}},
                  "kernel assumed for the report's single-point radius r0 (the surrogate's kernel)")};
  return set;
}
}  // namespace

VARBO_PLUGIN("region_confidence", "0.1.0", "Confidence region sigma_n <= gamma*sigma_f of cautious BO (CRBO)") {
  using namespace varbo;
  registry.add(make_component<RegionConstraint>(
      "confidence",
      "C_n = {theta : sigma_n(theta) <= gamma*sigma_f} on the latent predictive variance (Froehlich 2021, eq. 3); "
      "widened by x1.2 of the variance scale (up to 50 times) when only the data satisfy it",
      confidence_options().specs(),
      [](const Options& o, const BuildContext& ctx) -> std::unique_ptr<RegionConstraint> {
        if (ctx.dim <= 0) throw ConfigError("region 'confidence' needs the problem dimension (got 0)");
        return std::make_unique<ConfidenceRegion>(ctx.dim, confidence_options().read(o));
      },
      {"region:constraint"}, {"optimizer:constraints"}));
}
