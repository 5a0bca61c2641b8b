#include "random_search.hpp"
#include "varbo/plugin.hpp"

VARBO_PLUGIN("random", "0.1.0", "Random search baseline") {
  registry.add(varbo::make_component<varbo::Algorithm>(
      "random", "points from a sampler (uniform, lhs, sobol) over the whole budget; no model",
      {varbo::opt::component("sampler", varbo::Kind::Sampler, "uniform", "where the points come from")},
      [](const varbo::Options& o, const varbo::BuildContext& ctx) {
        return std::make_unique<varbo::random_search::RandomSearch>(o, ctx);
      },
      {"search_space:mixed"}));  // the study rounds and repairs each point (docs/search_space.md)
}
