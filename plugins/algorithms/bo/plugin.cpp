#include "bayesian_optimization.hpp"
#include "varbo/plugin.hpp"

VARBO_PLUGIN("bo", "0.1.0", "Bayesian optimization composed from a surrogate, acquisition, region and optimizer") {
  registry.add(varbo::make_component<varbo::Algorithm>(
      "bo",
      "model-based optimization: initial design, then fit surrogate / update region / maximize acquisition each "
      "trial; optional phases and ε-random exploration",
      varbo::bo::options(), [](const varbo::Options& o, const varbo::BuildContext& ctx) {
        return std::make_unique<varbo::bo::BayesianOptimization>(o, ctx);
      },
      // Typed parameters and constraints (docs/search_space.md): the surrogate sees rounded inputs, the region
      // is intersected with the constraints and every suggestion is made admissible.
      {"search_space:mixed"}));
}
