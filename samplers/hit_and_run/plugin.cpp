// Plugin `sampler_hit_and_run`: hit-and-run sampling inside a region (Fröhlich et al. 2021, Alg. 1).
#include "hit_and_run.hpp"
#include "varbo/plugin.hpp"

VARBO_PLUGIN("sampler_hit_and_run", "0.1.0", "Hit-and-run sampler of box ∩ region (CRBO, Alg. 1)") {
  using namespace varbo;
  registry.add(make_component<Sampler>(
      "hit_and_run",
      "Parallel hit-and-run chains from the region's seeds: random direction, chord by doubling and shrinkage, "
      "uniform point on it (Belisle 1993; Froehlich 2021, Alg. 1); chains and half of the samples carry over "
      "from one call to the next",
      {opt::integer("chains", 256, "parallel chains (at most the number of samples asked for)").at_least(1),
       opt::integer("burn_in", 10, "steps of each chain before its first sample").at_least(0),
       opt::integer("thinning", 1, "steps between kept samples of a chain").at_least(1),
       opt::real("width", 0.1, "initial bracket width w of the step-out (unit cube)").above(0),
       opt::integer("max_doublings", 10, "doublings of the bracket per chord").at_least(0),
       opt::integer("max_shrinks", 50, "rejections per chord before a chain stays put").at_least(1),
       opt::real("refresh", 0.5, "fraction of the samples drawn anew by each call; the rest are the previous "
                                 "call's newest samples still inside the region (reference CRBO: half)")
           .above(0)
           .at_most(1),
       opt::boolean("keep_chains", true, "continue each chain across calls from its last point while that is "
                                         "inside the region (false: restart from the seeds every call)")},
      [](const Options& o, const BuildContext&) -> std::unique_ptr<Sampler> {
        HitAndRunOptions h;
        h.chains = o.integer("chains");
        h.burn_in = o.integer("burn_in");
        h.thinning = o.integer("thinning");
        h.width = o.real("width");
        h.max_doublings = static_cast<int>(o.integer("max_doublings"));
        h.max_shrinks = static_cast<int>(o.integer("max_shrinks"));
        h.refresh = o.real("refresh");
        h.keep_chains = o.boolean("keep_chains");
        return std::make_unique<HitAndRunSampler>(h);
      }));
}
