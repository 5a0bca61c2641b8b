#include "random_search.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <stdexcept>

#include "varbo/errors.hpp"
#include "varbo/constrained_sampling.hpp"
#include "varbo/log.hpp"
#include "varbo/optimizer.hpp"

namespace varbo::random_search {

RandomSearch::RandomSearch(const Options& o, const BuildContext& ctx) {
  if (ctx.dim < 1) throw ConfigError("random: the problem dimension must be at least 1");
  sampler_ = ctx.registry->create<Sampler>(o.component("sampler"), ctx);
  sampler_name_ = o.component("sampler").info->full_name();
  // One point drawn now, in the plain box, so that a sampler that cannot serve this problem (sobol beyond its 3667
  // dimensions) is refused with the configuration's key before anything is created; the points come later, lazily
  // (audit, session 45: the error had no location and left a run folder behind).
  {
    Rng probe(ctx.seed);
    (void)sample_named(*sampler_, sampler_name_, BoxRegion(Box::unit(ctx.dim)), 1, probe);
  }
  seed_ = ctx.seed;
  dim_ = ctx.dim;
  // No budget (0: the Python ask/tell API and the Optuna sampler when the caller gives none) is no limit: it handed
  // out one point and then nothing, so the Optuna sampler fell back to its independent sampler silently (red team,
  // session 24). Blocks of kBlock points then follow one another, each its own stream.
  budget_ = ctx.budget > 0 ? ctx.budget : kUnbounded;
  // Up to kBlock points: the whole budget in one draw, so a low-discrepancy sampler keeps its structure. A
  // larger budget is drawn in blocks of kBlock (each its own random stream), one block in memory at a time.
  block_ = std::min(budget_, kBlock);
  initial_point_ = ctx.initial_point;
  data_ = Dataset::empty(ctx.dim);
}

void RandomSearch::set_search_space(SharedSpace space) {
  space_ = std::move(space);
  loaded_block_ = -1;  // drawn again with the constraints
}

std::optional<Vec> RandomSearch::point(Index k) {
  const Index b = k / block_;
  if (b != loaded_block_) {
    Rng rng = Rng(seed_).stream(1);
    // Blocks past the budget (points passed over as evaluated already) have streams of their own.
    if (budget_ > kBlock || b * block_ >= budget_) rng = rng.stream(static_cast<std::uint64_t>(b));
    const Index left = budget_ - b * block_;
    const Index want = left > 0 ? std::min(block_, left) : block_;
    points_ = sample_unit_cube(*sampler_, sampler_name_, space_, dim_, want, rng);
    // Fewer points than asked is the sampler's bug (a box always holds n points): it ended the run early as
    // "nothing more to suggest", exit 0, the budget unspent (red team, session 23).
    if (points_.rows() != want)
      throw std::runtime_error(fmt::format("random: sampler '{}' returned {} points when asked for {}; its sample() "
                                           "is wrong",
                                           sampler_name_, points_.rows(), want));
    if (b == 0 && initial_point_ && points_.rows() > 0) points_.row(0) = initial_point_->transpose();
    loaded_block_ = b;
  }
  if (k - b * block_ >= points_.rows()) return std::nullopt;  // the sampler gave fewer points than asked
  return Vec(points_.row(k - b * block_).transpose());
}

std::vector<Suggestion> RandomSearch::ask(Index q) {
  std::vector<Suggestion> out;
  Index passed_pending = 0;  // pending elsewhere: passed over in this process only (no state is saved then)
  Index repeats = 0;         // evaluated points in a row
  while (static_cast<Index>(out.size()) < q && next_ + skip_ < budget_ + skipped_ + passed_pending) {
    std::optional<Vec> x = point(next_ + skip_);
    ++next_;
    if (!x) break;
    const std::vector<double> key(x->data(), x->data() + x->size());
    if (told_.count(key)) {
      ++skipped_;  // evaluated already (out of order): never hand a point out twice
      // A sampler that gives only points evaluated already (around_initial_point with radius 0, an unscrambled
      // Sobol sequence, which restarts with each block) kept this loop drawing block after block at full CPU,
      // deaf to Ctrl-C (red team, session 26): a whole block of them ends the search.
      if (++repeats >= block_) {
        log_warn("random: sampler '{}' gave {} points in a row that were evaluated already (it repeats its points: "
                 "an unscrambled sequence restarts with each block of {}); nothing more to suggest",
                 sampler_name_, repeats, block_);
        break;
      }
      continue;
    }
    repeats = 0;
    if (pending_.count(key)) {
      ++passed_pending;
      continue;
    }
    out.push_back(Suggestion{*x, "random", 0, 0});
  }
  return out;
}

void RandomSearch::set_pending(const std::vector<Vec>& pending) {
  skip_ = static_cast<Index>(pending.size());
  pending_.clear();
  for (const Vec& p : pending) pending_.insert(std::vector<double>(p.data(), p.data() + p.size()));
}

void RandomSearch::tell(const std::vector<Observation>& observations) {
  for (const auto& o : observations) {
    told_.insert(std::vector<double>(o.x.data(), o.x.data() + o.x.size()));
    if (o.ok) data_.add(o.x, o.cost);
  }
}

std::optional<Vec> RandomSearch::recommendation() const {
  if (data_.size() == 0) return std::nullopt;
  Index best;
  data_.y.minCoeff(&best);
  return Vec(data_.X.row(best).transpose());
}

}  // namespace varbo::random_search
