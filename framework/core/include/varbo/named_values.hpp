#pragma once
// θ of (name, text) pairs: what `varbo observe new --param name=value` and Python's Study.tell_point({name: value})
// take, parsed by one function so both accept and refuse the same values.
#include <string>
#include <utility>
#include <vector>

#include "varbo/search_space.hpp"

namespace varbo {

/// θ (user units) of (name, text) pairs, each value parsed by SearchSpace::parse_value: every parameter named once
/// (a fixed one may be left out, it keeps its value). InputError naming the parameter, prefixed by `what`
/// ("--param", "tell_point"), otherwise.
Vec theta_of_named(const SearchSpace& space, const std::vector<std::pair<std::string, std::string>>& values,
                   const std::string& what);

}  // namespace varbo
