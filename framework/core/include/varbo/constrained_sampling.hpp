#pragma once
// Points of the unit cube drawn inside a study's linear constraints, for the algorithms that draw designs or random
// points themselves (bo's initial and fresh-start designs, random search). Drawn over the whole cube, the
// infeasible ones were projected onto the constraint's boundary by the study's repair: with `a + b <= 0.3`
// every design point lay on that line (docs/search_space.md).
#include <string>

#include "varbo/sampler.hpp"
#include "varbo/search_space.hpp"

namespace varbo {

/// n points from `sampler` over the unit cube of dimension d, inside `space`'s linear constraints when it has any
/// (the sampler's rejection), topped up with points of the whole cube when the feasible set is too small to be
/// found by rejection (the study then repairs them). Without constraints: exactly the sampler's points over the cube.
Mat sample_unit_cube(const Sampler& sampler, const SharedSpace& space, Index d, Index n, Rng& rng);
/// The same, with the sampler's exceptions named as sample_named() does (an empty name: not named).
Mat sample_unit_cube(const Sampler& sampler, const std::string& sampler_name, const SharedSpace& space, Index d,
                     Index n, Rng& rng);

/// sampler.sample(region, n, rng); an exception that is not one of varbo's own (varbo::Error) comes out as a
/// PluginCodeError naming the sampler: a third-party sampler's std::runtime_error was blamed on the algorithm that
/// drew its design ("algorithm 'bo/bo' could not be created: ..."; red team, session 31).
Mat sample_named(const Sampler& sampler, const std::string& sampler_name, const RegionConstraint& region, Index n,
                 Rng& rng);

}  // namespace varbo
