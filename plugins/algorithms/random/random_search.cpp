#include "random_search.hpp"

#include "varbo/errors.hpp"

namespace varbo::random_search {

RandomSearch::RandomSearch(const Options& o, const BuildContext& ctx) {
  if (ctx.dim < 1) throw ConfigError("random: the problem dimension must be at least 1");
  auto sampler = ctx.registry->create<Sampler>(o.component("sampler"), ctx);
  Rng rng = Rng(ctx.seed).stream(1);
  // The whole budget at once, so a low-discrepancy sampler keeps its structure.
  points_ = sampler->sample(BoxRegion(Box::unit(ctx.dim)), std::max<Index>(ctx.budget, 1), rng);
  if (ctx.initial_point && points_.rows() > 0) points_.row(0) = ctx.initial_point->transpose();
  data_ = Dataset::empty(ctx.dim);
}

std::vector<Suggestion> RandomSearch::ask(Index q) {
  std::vector<Suggestion> out;
  for (Index j = 0; j < q && next_ + skip_ < points_.rows(); ++j, ++next_)
    out.push_back(Suggestion{points_.row(next_ + skip_).transpose(), "random", 0, 0});
  return out;
}

void RandomSearch::tell(const std::vector<Observation>& observations) {
  for (const auto& o : observations)
    if (o.ok) data_.add(o.x, o.cost);
}

std::optional<Vec> RandomSearch::recommendation() const {
  if (data_.size() == 0) return std::nullopt;
  Index best;
  data_.y.minCoeff(&best);
  return Vec(data_.X.row(best).transpose());
}

}  // namespace varbo::random_search
