// Plugin `sample_polish`: CRBO's acquisition optimizer — region samples, then constrained SQP from the best few.
#include "sample_polish.hpp"
#include "varbo/errors.hpp"
#include "varbo/plugin.hpp"

VARBO_PLUGIN("sample_polish", "0.1.0", "Sample the region, polish the best few with constrained SLSQP (CRBO)") {
  using namespace varbo;
  registry.add(make_component<Optimizer>(
      "sample_polish",
      "Evaluates f on samples of the region (hit-and-run by default) and polishes the best few with NLopt SLSQP "
      "(COBYLA without gradients) under the region constraint and box bounds; keeps the best feasible point",
      {opt::component("sampler", Kind::Sampler, "hit_and_run", "sampler that draws the candidates in the region"),
       opt::integer("samples", 1000, "number of region samples evaluated").at_least(1),
       opt::integer("polish", 3, "local searches started from the best samples").at_least(0),
       opt::real("polish_halfwidth", 0.1, "half-width of the box around each start the local search may use "
                                          "(unit cube; the reference implementation uses 0.5 lengthscales)").above(0),
       opt::integer("max_iterations", 100, "evaluations per local search").at_least(1),
       opt::real("tolerance", 1e-4, "relative x and f tolerance of the local search").above(0)},
      [](const Options& o, const BuildContext& ctx) -> std::unique_ptr<Optimizer> {
        if (ctx.registry == nullptr) throw ConfigError("sample_polish: built without a registry for its sampler");
        SamplePolishOptions s;
        s.samples = o.integer("samples");
        s.polish = o.integer("polish");
        s.polish_halfwidth = o.real("polish_halfwidth");
        s.max_iterations = static_cast<int>(o.integer("max_iterations"));
        s.tolerance = o.real("tolerance");
        return std::make_unique<SamplePolishOptimizer>(ctx.registry->create<Sampler>(o.component("sampler"), ctx), s);
      },
      {"optimizer:constraints"}));
}
