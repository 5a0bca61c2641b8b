// Plugin `sampler_hit_and_run`: hit-and-run sampling inside a region (Fröhlich et al. 2021, Alg. 1).
#include "hit_and_run.hpp"
#include "varbo/option_set.hpp"
#include "varbo/plugin.hpp"

namespace {
using varbo::HitAndRunOptions;
namespace opt = varbo::opt;
const varbo::OptionSet<HitAndRunOptions>& hit_and_run_options() {
  static const varbo::OptionSet<HitAndRunOptions> set{
      opt::integer("chains", &HitAndRunOptions::chains, "parallel chains (at most the number of samples asked for)")
          .at_least(1),
      opt::integer("burn_in", &HitAndRunOptions::burn_in, "steps of each chain before its first sample").at_least(0),
      opt::integer("thinning", &HitAndRunOptions::thinning, "steps between kept samples of a chain").at_least(1),
      opt::real("width", &HitAndRunOptions::width, "initial bracket width w of the step-out (unit cube)").above(0),
      opt::integer("max_doublings", &HitAndRunOptions::max_doublings, "doublings of the bracket per chord").at_least(0),
      opt::integer("max_shrinks", &HitAndRunOptions::max_shrinks, "rejections per chord before a chain stays put")
          .at_least(1),
      opt::real("refresh", &HitAndRunOptions::refresh,
                "fraction of the samples drawn anew by each call; the rest are the previous "
                "call's newest samples still inside the region (reference CRBO: half)")
          .above(0)
          .at_most(1),
      opt::boolean("keep_chains", &HitAndRunOptions::keep_chains,
                   "continue each chain across calls from its last point while that is "
                   "inside the region (false: restart from the seeds every call)")};
  return set;
}
}  // namespace

VARBO_PLUGIN("sampler_hit_and_run", "0.1.0", "Hit-and-run sampler of box ∩ region (CRBO, Alg. 1)") {
  using namespace varbo;
  registry.add(make_component<Sampler>(
      "hit_and_run",
      "Parallel hit-and-run chains from the region's seeds: random direction, chord by doubling and shrinkage, "
      "uniform point on it (Belisle 1993; Froehlich 2021, Alg. 1); chains and half of the samples carry over "
      "from one call to the next",
      hit_and_run_options().specs(),
      [](const Options& o, const BuildContext&) -> std::unique_ptr<Sampler> {
        return std::make_unique<HitAndRunSampler>(hit_and_run_options().read(o));
      }));
}
