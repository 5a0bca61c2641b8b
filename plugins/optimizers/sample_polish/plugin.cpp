// Plugin `sample_polish`: CRBO's acquisition optimizer — region samples, then constrained SQP from the best few.
#include "sample_polish.hpp"
#include "varbo/errors.hpp"
#include "varbo/option_set.hpp"
#include "varbo/plugin.hpp"

namespace {
using varbo::SamplePolishOptions;
namespace opt = varbo::opt;
const varbo::OptionSet<SamplePolishOptions>& sample_polish_options() {
  static const varbo::OptionSet<SamplePolishOptions> set{
      opt::component("sampler", varbo::Kind::Sampler, "hit_and_run", "sampler that draws the candidates in the region"),
      opt::integer("samples", &SamplePolishOptions::samples,
                   "number of region samples evaluated (at most 10^6: they are held in memory at once)")
          .at_least(1)
          .at_most(1e6),
      opt::integer("polish", &SamplePolishOptions::polish, "local searches started from the best samples").at_least(0),
      opt::real("polish_halfwidth", &SamplePolishOptions::polish_halfwidth,
                "half-width of the box around each start the local search may use "
                "(unit cube; the reference implementation uses 0.5 lengthscales)")
          .above(0),
      opt::integer("max_iterations", &SamplePolishOptions::max_iterations, "evaluations per local search").at_least(1),
      opt::real("tolerance", &SamplePolishOptions::tolerance, "relative x and f tolerance of the local search")
          .above(0)};
  return set;
}
}  // namespace

VARBO_PLUGIN("sample_polish", "0.1.0", "Sample the region, polish the best few with constrained SLSQP (CRBO)") {
  using namespace varbo;
  registry.add(make_component<Optimizer>(
      "sample_polish",
      "Evaluates f on samples of the region (hit-and-run by default) and polishes the best few with NLopt SLSQP "
      "(COBYLA without gradients) under the region constraint and box bounds; keeps the best feasible point",
      sample_polish_options().specs(),
      [](const Options& o, const BuildContext& ctx) -> std::unique_ptr<Optimizer> {
        if (ctx.registry == nullptr) throw ConfigError("sample_polish: built without a registry for its sampler");
        const SamplePolishOptions s = sample_polish_options().read(o);
        return std::make_unique<SamplePolishOptimizer>(ctx.registry->create<Sampler>(o.component("sampler"), ctx), s);
      },
      {"optimizer:constraints"}));
}
