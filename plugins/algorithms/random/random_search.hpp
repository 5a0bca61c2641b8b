#pragma once
// The baseline every method must beat: points from a sampler, no model.
#include <memory>
#include <set>
#include <vector>

#include "varbo/registry.hpp"
#include "varbo/search_space.hpp"
#include "varbo/state.hpp"

namespace varbo::random_search {

class RandomSearch final : public Algorithm, public AlgorithmState, public SpaceAware {
 public:
  /// Points are drawn a block at a time when first asked for, so a huge budget costs no memory up front.
  static constexpr Index kBlock = 4096;
  /// The sequence length when no budget is given (ctx.budget 0): as good as endless.
  static constexpr Index kUnbounded = Index{1} << 50;

  RandomSearch(const Options& options, const BuildContext& ctx);
  std::vector<Suggestion> ask(Index q) override;
  void tell(const std::vector<Observation>& observations) override;
  /// Points pending elsewhere took the next samples: skip that many, so concurrent workers get distinct ones
  /// (and any sample equal to a pending point: after results out of order the count alone fell short).
  void set_pending(const std::vector<Vec>& pending) override;
  std::optional<Vec> recommendation() const override;
  /// Snapshot: the sample counter (the data come back through the history).
  std::optional<std::string> save_state() const override;
  void restore_state(const std::string& state, const std::vector<Observation>& history) override;
  /// With linear constraints the samples are drawn inside them (rejection), not over the whole cube: the study's
  /// repair projected the infeasible ones onto the boundary, and with `a + b <= 0.3` every point lay on that line.
  void set_search_space(SharedSpace space) override;

 private:
  std::optional<Vec> point(Index k);  ///< the k-th point of the sequence (blocks past the budget on demand)

  std::unique_ptr<Sampler> sampler_;
  std::string sampler_name_;  ///< plugin/name, for messages about what it returns
  std::uint64_t seed_ = 0;
  Index dim_ = 0;
  Index budget_ = 1;
  Index block_ = 1;          ///< points per block: the whole budget when it is at most kBlock
  Index loaded_block_ = -1;  ///< which block `points_` holds
  std::optional<Vec> initial_point_;
  Mat points_;
  Index next_ = 0;
  Index skip_ = 0;
  /// Sequence points passed over because they had been evaluated already: a trial abandoned out of order left the
  /// counter behind the results (the replay asks once per result), and the next point repeated an evaluated one.
  Index skipped_ = 0;
  std::set<std::vector<double>> told_;  ///< every evaluated point, failed ones too (exact coordinates)
  std::set<std::vector<double>> pending_;  ///< points pending elsewhere (set_pending)
  Dataset data_;
  SharedSpace space_;  ///< typed parameters and constraints (null: a plain box)
};

}  // namespace varbo::random_search
