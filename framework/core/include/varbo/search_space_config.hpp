#pragma once
// The `parameters:` and `constraints:` keys of a study file, validated with file:line:col like every key.
#include "varbo/config.hpp"
#include "varbo/search_space.hpp"

namespace varbo {

/// `parameters:` — a list of {name, type: real|int|categorical|fixed, low, high, log, choices, value}.
/// Every problem (unknown key, low ≥ high, log with low ≤ 0, empty or duplicate choices, duplicate names, ...)
/// throws ConfigError at the offending key.
SearchSpace parse_search_space(const ConfigNode& parameters);

/// `constraints:` — a list of strings such as "t1 + 2*t2 - t3 <= 5.5" in user units, added to `space`, which is
/// then finalized; an empty feasible set is a ConfigError at the list.
void add_constraints(SearchSpace& space, const ConfigNode& constraints);

}  // namespace varbo
