// Plugin `sampler_hit_and_run`: hit-and-run sampling inside a region (Fröhlich et al. 2021, Alg. 1).
#include "hit_and_run.hpp"
#include "varbo/plugin.hpp"

VARBO_PLUGIN("sampler_hit_and_run", "0.1.0", "Hit-and-run sampler of box ∩ region (CRBO, Alg. 1)") {
  using namespace varbo;
  registry.add(make_component<Sampler>(
      "hit_and_run",
      "Parallel hit-and-run chains from the region's seeds: random direction, chord by doubling and shrinkage, "
      "uniform point on it (Belisle 1993; Froehlich 2021, Alg. 1)",
      {opt::integer("chains", 256, "parallel chains (at most the number of samples asked for)").at_least(1),
       opt::integer("burn_in", 10, "steps of each chain before its first sample").at_least(0),
       opt::integer("thinning", 1, "steps between kept samples of a chain").at_least(1),
       opt::real("width", 0.1, "initial bracket width w of the step-out (unit cube)").above(0),
       opt::integer("max_doublings", 10, "doublings of the bracket per chord").at_least(0),
       opt::integer("max_shrinks", 50, "rejections per chord before a chain stays put").at_least(1)},
      [](const Options& o, const BuildContext&) -> std::unique_ptr<Sampler> {
        HitAndRunOptions h;
        h.chains = o.integer("chains");
        h.burn_in = o.integer("burn_in");
        h.thinning = o.integer("thinning");
        h.width = o.real("width");
        h.max_doublings = static_cast<int>(o.integer("max_doublings"));
        h.max_shrinks = static_cast<int>(o.integer("max_shrinks"));
        return std::make_unique<HitAndRunSampler>(h);
      }));
}
