#pragma once
// The baseline every method must beat: points from a sampler, no model.
#include "varbo/registry.hpp"

namespace varbo::random_search {

class RandomSearch final : public Algorithm {
 public:
  RandomSearch(const Options& options, const BuildContext& ctx);
  std::vector<Suggestion> ask(Index q) override;
  void tell(const std::vector<Observation>& observations) override;
  std::optional<Vec> recommendation() const override;

 private:
  Mat points_;
  Index next_ = 0;
  Dataset data_;
};

}  // namespace varbo::random_search
