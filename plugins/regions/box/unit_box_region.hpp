#pragma once
// The `box` region: the whole unit cube of the problem, with the evaluated points as search seeds.
#include "varbo/region.hpp"

namespace varbo::regions {

class UnitBoxRegion final : public RegionConstraint {
 public:
  explicit UnitBoxRegion(Index dim);
  /// Keeps the data points (unit cube) as seeds for the acquisition search.
  void update(const Surrogate* model, const Dataset& data, Rng& rng) override;
  const Box& bounds() const override { return box_; }
  Mat seeds() const override { return seeds_; }
  std::string state() const override;

 private:
  Box box_;
  Mat seeds_;
};

}  // namespace varbo::regions
