#pragma once
// The task `python` of the studies varbo.minimize writes: a domain — a box (lower, upper, names) or, with no box,
// the study's `parameters:` (as the external task takes them) — whose evaluation the embedding host supplies. The
// Python module registers it with its evaluator; the CLI registers it without one, so `varbo status` and
// `varbo export` read such a study (an evaluation outside the host is a failed trial saying why).
#include <functional>
#include <string>
#include <vector>

#include "varbo/registry.hpp"
#include "varbo/search_space.hpp"

namespace varbo {

/// Evaluates θ (user units) of a task whose parameter names and typed space (null: a box of reals) are given.
using HostEvaluator =
    std::function<Evaluation(const Vec& theta, const std::vector<std::string>& names, const SearchSpace* space)>;

/// Adds the task `python` to `registry`. `evaluator_at_build()` is called each time the task is built and gives its
/// evaluator (an empty function: the task has none).
void add_host_python_task(Registry& registry, std::function<HostEvaluator()> evaluator_at_build = {});

}  // namespace varbo
