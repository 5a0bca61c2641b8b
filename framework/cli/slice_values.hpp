#pragma once
// The values at which a model is cut along one typed parameter (`varbo plot --slice`, the dashboard's slices):
// a grid of n (geometric for a log parameter), every integer when there are fewer than n, every category (its
// index).
#include <algorithm>
#include <cmath>
#include <vector>

#include "varbo/search_space.hpp"

namespace varbo::cli {

inline std::vector<double> slice_values(const Parameter& par, int n) {
  std::vector<double> values;
  if (par.type == ParameterType::Categorical) {
    for (std::size_t j = 0; j < par.choices.size(); ++j) values.push_back(static_cast<double>(j));
    return values;
  }
  if (par.type == ParameterType::Fixed) return {par.value};
  const bool every_integer = par.type == ParameterType::Int && par.high - par.low < n;
  const int count = every_integer ? static_cast<int>(par.high - par.low) + 1 : n;
  for (int k = 0; k < count; ++k) {
    const double u = static_cast<double>(k) / std::max(1, count - 1);
    double v = par.log ? std::exp(std::log(par.low) + u * (std::log(par.high) - std::log(par.low)))
                       : par.low + u * (par.high - par.low);
    if (par.type == ParameterType::Int) v = every_integer ? par.low + k : std::round(v);
    values.push_back(std::clamp(v, par.low, par.high));
  }
  return values;
}

}  // namespace varbo::cli
