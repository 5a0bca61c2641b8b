#pragma once
// The baseline every method must beat: points from a sampler, no model.
#include "varbo/registry.hpp"

namespace varbo::random_search {

class RandomSearch final : public Algorithm {
 public:
  RandomSearch(const Options& options, const BuildContext& ctx);
  std::vector<Suggestion> ask(Index q) override;
  void tell(const std::vector<Observation>& observations) override;
  /// Points pending elsewhere took the next samples: skip that many, so concurrent workers get distinct ones.
  void set_pending(const std::vector<Vec>& pending) override { skip_ = static_cast<Index>(pending.size()); }
  std::optional<Vec> recommendation() const override;

 private:
  Mat points_;
  Index next_ = 0;
  Index skip_ = 0;
  Dataset data_;
};

}  // namespace varbo::random_search
