// The search space of a study (docs/search_space.md), shared by Study and the run-folder reader.
#include <fmt/format.h>

#include <algorithm>

#include "varbo/errors.hpp"
#include "varbo/search_space_config.hpp"
#include "varbo/study.hpp"

namespace varbo {

/// The study's search space (docs/search_space.md): the declared `parameters:` (the task must take them), or
/// the task's own typed space, or — with `constraints:` only — the task's box as real parameters; null for a
/// plain box, which keeps every run without these keys exactly as before.
SharedSpace resolve_study_space(const StudyConfig& config, Task& task, Domain& domain) {
  auto* aware = dynamic_cast<SpaceAware*>(&task);
  if (config.parameters) {
    if (!aware || aware->search_space())
      config.source.child("parameters")
          .fail(fmt::format("task '{}' defines its own domain; `parameters:` is for tasks that take one (external)",
                            config.task.info->name));
    aware->set_search_space(config.parameters);
  }
  domain = task.domain();
  SharedSpace space = aware ? aware->search_space() : nullptr;
  if (config.constraints.defined()) {
    SearchSpace s = space ? *space : SearchSpace::from_box(domain.box, domain.names);
    add_constraints(s, config.constraints);
    space = std::make_shared<const SearchSpace>(std::move(s));
  }
  if (!space) return space;
  domain.box = space->user_box();
  domain.names = space->names();
  // Components that cannot work on integers, categories or constraints say so (capability tags).
  const bool mixed = space->has_discrete() || space->has_constraints();
  const auto& provides = config.algorithm.info->provides;
  if (mixed && std::find(provides.begin(), provides.end(), "search_space:mixed") == provides.end())
    throw ConfigError(fmt::format(
        "{}: algorithm '{}' does not handle integer or categorical parameters or constraints (it lacks the "
        "capability 'search_space:mixed'; its steps are continuous); use bo, random or cma_es",
        config.algorithm.source.where(), config.algorithm.info->name));
  if (space->has_constraints())
    for (const auto& o : config.algorithm.info->options) {
      if (o.type != OptionType::Component || o.component_kind != Kind::Optimizer || o.name != "acquisition_optimizer" ||
          !config.algorithm.options.is_set(o.name))
        continue;
      const ResolvedComponent& rc = config.algorithm.options.component(o.name);
      const auto& p = rc.info->provides;
      if (std::find(p.begin(), p.end(), "optimizer:constraints") == p.end())
        throw ConfigError(fmt::format("{}: key 'algorithm.{}': optimizer '{}' ignores region constraints, so it "
                                      "cannot keep to `constraints:`; use multistart, nlopt, random_search or "
                                      "sample_polish",
                                      config.algorithm.options.node(o.name).where(), o.name, rc.info->name));
    }
  return space;
}

}  // namespace varbo
