#include "unit_box_region.hpp"

#include <fmt/format.h>

#include "varbo/errors.hpp"

namespace varbo::regions {

UnitBoxRegion::UnitBoxRegion(Index dim) : box_(Box::unit(dim)), seeds_(0, dim) {
  if (dim < 1) throw ConfigError("region 'box': the problem dimension must be at least 1, got " + std::to_string(dim));
}

void UnitBoxRegion::update(const Surrogate*, const Dataset& data, Rng&) {
  if (data.size() > 0 && data.dim() != box_.dim())
    throw InputError(fmt::format("region 'box': data of dimension {} for a {}-dimensional problem", data.dim(),
                                 box_.dim()));
  seeds_.resize(0, box_.dim());
  // Only points inside the cube are valid seeds (the data should all be inside; clamp defensively).
  seeds_.resize(data.size(), box_.dim());
  for (Index i = 0; i < data.size(); ++i) seeds_.row(i) = box_.clamp(data.X.row(i).transpose()).transpose();
}

std::string UnitBoxRegion::state() const {
  return fmt::format("box: unit cube of dimension {}, {} seeds", box_.dim(), seeds_.rows());
}

}  // namespace varbo::regions
