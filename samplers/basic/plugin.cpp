// libvarbo_samplers.so: uniform, Latin hypercube and Sobol samplers.
#include "region_samplers.hpp"
#include "varbo/plugin.hpp"

VARBO_PLUGIN("samplers", "0.1.0", "Uniform, Latin hypercube and Sobol samplers over a region") {
  using varbo::BuildContext;
  using varbo::Options;
  using varbo::Sampler;
  registry.add(varbo::make_component<Sampler>(
      "uniform", "i.i.d. uniform points in the region's box (rejection for a constrained region)", {},
      varbo::Factory<Sampler>(
          [](const Options&, const BuildContext&) { return std::make_unique<varbo::sampling::UniformSampler>(); })));
  registry.add(varbo::make_component<Sampler>(
      "lhs", "Latin hypercube: each of n strata hit exactly once per dimension", {},
      varbo::Factory<Sampler>([](const Options&, const BuildContext&) {
        return std::make_unique<varbo::sampling::LatinHypercubeSampler>();
      })));
  registry.add(varbo::make_component<Sampler>(
      "sobol",
      "Sobol low-discrepancy sequence (Boost.Random), randomized by a digital shift; for a few points in many "
      "dimensions prefer lhs (the first Sobol points lie on a few diagonal lines)",
      {varbo::opt::boolean("scramble", true,
                           "apply a random digital shift drawn from the seed (false: the plain sequence, "
                           "the same for every seed)")},
      varbo::Factory<Sampler>([](const Options& o, const BuildContext&) {
        return std::make_unique<varbo::sampling::SobolSampler>(o.boolean("scramble"));
      })));
}
