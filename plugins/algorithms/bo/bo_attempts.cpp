// Attempts of a bo run (docs/defaults.md): a fresh start's design away from the earlier attempts' minima, the
// model data of the current attempt, and the final refinement on the basin of the incumbent.
#include "bayesian_optimization.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "bo_streams.hpp"
#include "varbo/errors.hpp"
#include "varbo/log.hpp"
#include "varbo/option_set.hpp"
#include "varbo/space_wrappers.hpp"
#include "varbo/value_stall.hpp"

namespace varbo::bo {

void BayesianOptimization::begin_fresh_attempt(Index k, int fresh_starts, const Dataset& data) {
  fresh_starts_ = fresh_starts;
  fresh_trial_ = k;
  fresh_from_ = data.size();
  attempt_starts_.push_back(fresh_from_);
  follow_anchor_ = -1;  // an attempt with a design (follow_probe sets its anchor after this)
}

Vec BayesianOptimization::fresh_design_point(Index k, bool refit) {
  Rng drng = rng_.stream(kFreshDesign, static_cast<std::uint64_t>(fresh_starts_));
  const Mat design = restart_away_ ? design_away_from_minima(drng)
                                   : design_sample(restart_points_, drng);
  const Index last = design.rows() - 1, row = k - fresh_trial_;
  if (row == 0 && failure_settings_.global_probe)
    if (std::optional<Vec> probe = global_probe(k, refit, "the fresh start's first point")) {
      probe_trial_ = k;
      return *probe;
    }
  const Vec x = design.row(replicate_design_ && last >= 1 && row == last ? 0 : row).transpose();
  // A design point where failure is likely (the failure model of every trial so far) is replaced by a point where
  // success is likely: a new design must not repeat known failures (issue 11). By default (design_repair: nearest,
  // session 33) the nearest likely success, which keeps the design's coverage at the failure region's face, where a
  // basin the region cuts begins; with design_repair: farthest (or when no direction finds one) the likely success
  // farthest from the design's other likely successes and (restart_design: away) from the earlier attempts' minima:
  // an arbitrary random point put Hartmann-6's new attempt next to the old minimum, and the attempt returned to
  // that basin (docs/failures.md).
  if (update_feasibility(k, refit) && feasibility_->probability(x) < exclusion_threshold_) {
    Rng rr = rng_.stream(kRandom, static_cast<std::uint64_t>(k));
    if (failure_settings_.design_repair == "nearest")
      if (std::optional<Vec> near = nearest_likely_success(
              [this](const Vec& z) { return feasibility_->probability(z); }, x, exclusion_threshold_, rr))
        return *near;
    std::vector<Vec> away = restart_away_ ? earlier_minima() : std::vector<Vec>{};
    for (Index i = 0; i < design.rows(); ++i)
      if (i != row && feasibility_->probability(design.row(i).transpose()) >= exclusion_threshold_)
        away.push_back(design.row(i).transpose());
    return feasible_point_away(rr, away, exclusion_threshold_);
  }
  return x;
}

Vec BayesianOptimization::feasible_point_away(Rng& rng, const std::vector<Vec>& away, double min_p) const {
  Vec best, likeliest;
  double best_distance = -1, best_p = -1;
  for (int i = 0; i < 64; ++i) {
    Vec x = random_point(rng);
    const double p = feasibility_->probability(x);
    if (p >= min_p) {
      double distance = std::numeric_limits<double>::infinity();
      for (const Vec& a : away) distance = std::min(distance, (x - a).norm());
      if (distance > best_distance) {
        best_distance = distance;
        best = x;
      }
    }
    if (p > best_p) {
      best_p = p;
      likeliest = std::move(x);
    }
  }
  return best_distance >= 0 ? best : likeliest;
}

std::vector<Vec> BayesianOptimization::earlier_minima() const {
  // The best point of every earlier attempt (the successful observations before the latest fresh start, split at
  // attempt_starts_).
  const Index before = std::min(fresh_from_, data_.size());
  std::vector<Vec> minima;
  Index lo = 0;
  for (std::size_t i = 0; i <= attempt_starts_.size(); ++i) {
    const Index hi = i < attempt_starts_.size() ? std::min(attempt_starts_[i], before) : before;
    if (hi > lo) {
      Index arg = 0;
      data_.y.segment(lo, hi - lo).minCoeff(&arg);
      minima.push_back(data_.X.row(lo + arg).transpose());
    }
    lo = std::max(lo, hi);
  }
  return minima;
}

Mat BayesianOptimization::design_away_from_minima(Rng& rng) const {
  // The best point of every earlier attempt (the successful observations before the latest fresh start, split at
  // attempt_starts_): a new design point inside a converged basin becomes the new attempt's best point and leads
  // its trust region back there. Of 16 designs, the one whose nearest point to those minima is farthest.
  const std::vector<Vec> minima = earlier_minima();
  Mat best;
  double best_score = -1;
  for (int c = 0; c < 16; ++c) {
    Mat design = design_sample(restart_points_, rng);
    double score = std::numeric_limits<double>::infinity();
    for (Index i = 0; i < design.rows(); ++i)
      for (const Vec& m : minima) score = std::min(score, (design.row(i).transpose() - m).norm());
    if (score > best_score) {
      best_score = score;
      best = std::move(design);
    }
  }
  return best;
}

bool BayesianOptimization::refinement_waits(Index k, const Dataset& data) const {
  // failure_model.refine_waits (session 42; docs/failures.md, item 13). Once a trial has failed the refinement takes
  // 2(d + 1) trials (refine_last), d + 1 more than without failures, and they came from a last attempt still on its
  // way down: Hartmann-6, held-out ball 5, seed 26 — the second attempt went −1.35 → −2.65 in its last seven
  // successes, 0.15 from the global minimiser, when the refinement returned to the incumbent, a local minimum
  // (−3.19) beside the ball that it could not improve. The extra trials go to such an attempt first: the refinement
  // waits while the attempt, past its design, is in another basin than the incumbent and at the pace of its last
  // d + 1 successes would pass the incumbent within d + 1 more, but never into bo's own last refine_last (d + 1)
  // trials, the refinement of a run without failures. Without that floor seed 26's attempt reached the global basin
  // and the refinement there (0.135 → 0.002), but on Branin, whose three minima are equal, an attempt in another
  // global basin always seemed about to pass the incumbent, and incumbents lost their polish (the disc at the
  // centre, 80 seeds: median 4.3e-10 → 1.1e-09, seed 21 1.4e-10 → 3.3e-04; with the floor 5.3e-10). Not for every
  // attempt still improving: a young attempt improves quickly anywhere, and waiting for it took the polish from
  // incumbents already at the global minimum (12 of the 80 seeds worse by 2× or more, 4 stuck runs rescued; with
  // the pace and the basin, none worse, 2 rescued).
  if (!failure_settings_.refine_waits || refining_ || fresh_starts_ == 0 || budget_ <= 0 || failed_.empty() ||
      !failure_settings_.active(static_cast<Index>(failed_.size())))
    return false;  // once a trial has failed only: a run without failures is unchanged
  if (k >= budget_ - configured_refine_last_ || k - fresh_trial_ < restart_points_) return false;
  const Index from = std::min(fresh_from_, data.size());
  const Index window = dim_ + 1;
  if (data.size() - from < 2) return false;
  Index best = from;
  for (Index i = from; i < data.size(); ++i)
    if (data.y(i) < data.y(best)) best = i;
  Index incumbent = 0;
  const double y_incumbent = data.y.minCoeff(&incumbent);
  const double gap = data.y(best) - y_incumbent;
  if (!(gap > 0)) return false;  // it holds the incumbent: the refinement polishes it
  if ((data.X.row(best) - data.X.row(incumbent)).lpNorm<Eigen::Infinity>() <= kAnotherBasin) return false;
  // Its best before its last d + 1 successes (its first success if it has no more).
  const Index split = std::max(from + 1, data.size() - window);
  const double before = data.y.segment(from, split - from).minCoeff();
  return before - data.y(best) > gap;
}

void BayesianOptimization::begin_refinement(Index k, const Dataset& data) {
  refining_ = true;
  Index best = 0;
  data.y.minCoeff(&best);
  // The attempt that found the incumbent: the successful observations [refine_lo_, refine_hi_).
  refine_lo_ = 0;
  refine_hi_ = data.size();
  for (const Index start : attempt_starts_) {
    if (start <= best) {
      refine_lo_ = start;
    } else {
      refine_hi_ = start;
      break;
    }
  }
  refine_from_ = data.size();
  refine_trial_ = k;
  log_info("bo: trial {}: the last {} trials refine the incumbent of all the data (found by attempt {}), on a model "
           "of {}", k, budget_ - k,
           std::upper_bound(attempt_starts_.begin(), attempt_starts_.end(), best) - attempt_starts_.begin() + 1,
           refine_local_ ? "the points near the incumbent"
           : refine_basin_ ? "that attempt and the points near the incumbent"
           : refine_attempt_model_ ? "that attempt's points" : "all the data");
  dynamic_cast<FreshStartRegion&>(*region_).return_to_incumbent();
}

Dataset BayesianOptimization::model_data_of(const Dataset& data) const {
  // The refinement's model, else the current attempt's (the points since the last fresh start), else all data.
  if (refining_ && refine_attempt_model_) {
    Dataset refined = refinement_data(data);
    if (refined.size() >= 2) return refined;
  }
  if (fresh_starts_ > 0 && !refining_ && follow_anchor_ >= 0 && follow_anchor_ == fresh_from_ &&
      follow_anchor_ < data.size())
    return data;  // an attempt continued from a global probe (bo_global_probe.cpp): the model that chose the probe
  if (fresh_starts_ > 0 && !refining_ && follow_anchor_ >= 0 && follow_anchor_ < data.size()) {
    // failure_model.follow_probe (session fail15): an attempt begun at a probe has no design of its own; its model
    // sees every point but those next to an earlier attempt's best (the basin it leaves), and the probe.
    const int n = failure_settings_.follow_points < 0 ? static_cast<int>(restart_points_) : failure_settings_.follow_points;
    Dataset local = Dataset::empty(dim_);
    if (n > 0) {
      // The probe's n nearest successful points (ties by index) and the attempt's own: what a design around the
      // probe would have told the model, without spending trials on it.
      const Vec probe = data.X.row(follow_anchor_).transpose();
      std::vector<std::pair<double, Index>> by_distance;
      for (Index i = 0; i < std::min(fresh_from_, data.size()); ++i)
        by_distance.emplace_back((data.X.row(i).transpose() - probe).lpNorm<Eigen::Infinity>(), i);
      const auto count = std::min<std::size_t>(static_cast<std::size_t>(n), by_distance.size());
      std::partial_sort(by_distance.begin(), by_distance.begin() + static_cast<std::ptrdiff_t>(count), by_distance.end());
      std::vector<Index> rows;
      for (std::size_t j = 0; j < count; ++j) rows.push_back(by_distance[j].second);
      std::sort(rows.begin(), rows.end());  // in the data's order
      for (const Index i : rows) local.add(data.X.row(i).transpose(), data.y(i));
      for (Index i = fresh_from_; i < data.size(); ++i) local.add(data.X.row(i).transpose(), data.y(i));
      if (local.size() >= 2) return local;
    }
    const double memory = failure_settings_.follow_memory;
    const std::vector<Vec> minima = earlier_minima();
    local = Dataset::empty(dim_);
    for (Index i = 0; i < data.size(); ++i) {
      bool keep = i == follow_anchor_ || i >= fresh_from_ || !(memory > 0);
      if (!keep) {
        keep = true;
        for (const Vec& m : minima) keep = keep && (data.X.row(i).transpose() - m).lpNorm<Eigen::Infinity>() > memory;
      }
      if (keep) local.add(data.X.row(i).transpose(), data.y(i));
    }
    if (local.size() >= 2) return local;
  }
  if (fresh_starts_ > 0 && !refining_ && data.size() >= fresh_from_ + 2) {
    Dataset local;
    const double memory = failure_settings_.attempt_memory;
    if (memory > 0 && !failed_.empty() && failure_settings_.active(static_cast<Index>(failed_.size()))) {
      // failure_model.attempt_memory (session fail14): once trials have failed, a fresh attempt's model also sees
      // the earlier attempts' points farther than attempt_memory (∞-norm) from every earlier attempt's best point:
      // it knows the landscape it already paid for, but not the basins it was sent away from.
      const std::vector<Vec> minima = earlier_minima();
      local = Dataset::empty(dim_);
      for (Index i = 0; i < data.size(); ++i) {
        bool keep = i >= fresh_from_;
        for (std::size_t j = 0; !keep && j <= minima.size(); ++j) {
          if (j == minima.size()) {
            keep = true;
            break;
          }
          if ((data.X.row(i).transpose() - minima[j]).lpNorm<Eigen::Infinity>() <= memory) break;
        }
        if (keep) local.add(data.X.row(i).transpose(), data.y(i));
      }
      return local;
    }
    local.X = data.X.bottomRows(data.size() - fresh_from_);
    local.y = data.y.tail(data.size() - fresh_from_);
    return local;
  }
  return data;
}

Dataset BayesianOptimization::refinement_data(const Dataset& data) const {
  // The incumbent's attempt and the refinement's own trials: one basin, so the fitted lengthscales are that
  // basin's (a model of every attempt's data refined Hartmann-6's global basin, found by the last attempt,
  // to 0.0057 against 0.00044; docs/defaults.md).
  const Index hi = std::min(refine_hi_, data.size()), from = std::min(std::max(refine_from_, hi), data.size());
  const Index lo = std::min(refine_lo_, hi);
  // refine_model: basin adds the other attempts' points next to the incumbent (within 0.1, half the refinement
  // box's side): on Branin every attempt converges to one of its three minima, and the incumbent's attempt alone
  // was too small a model (Branin 1.8e-08 against 1.2e-10 with all the data, docs/defaults.md).
  std::vector<Index> rows;
  Index best = 0;
  data.y.minCoeff(&best);
  if (refine_local_) {
    // refine_model: local: only the points next to the incumbent (within 0.1) once there are 2·(d + 1) of them —
    // a local GP (Gramacy & Apley 2015) whose lengthscales and output scale are those of the bowl being refined,
    // so its noise floor (relative to std(y)) is that of the bowl's costs, not of the whole range: Branin and
    // Hartmann-3 10× and 200× more precise, but Hartmann-6's late-found basins refined worse, so not the default
    // (docs/defaults.md). With fewer points (a basin found late) the basin's model below: a model of the
    // 2·(d + 1) nearest points refined those worse still.
    // The refinement's own trials stay in it wherever they landed (the region may grow past 0.1 on successes): a
    // model without them proposed the same θ again and again (session 16).
    for (Index i = 0; i < data.size(); ++i)
      if ((data.X.row(i) - data.X.row(best)).lpNorm<Eigen::Infinity>() <= 0.1 || i >= from) rows.push_back(i);
    if (static_cast<Index>(rows.size()) < 2 * (dim_ + 1)) rows.clear();
  }
  const bool local = !rows.empty();
  for (Index i = 0; i < data.size() && !local; ++i) {
    const bool own = (i >= lo && i < hi) || i >= from;
    const bool near = (data.X.row(i) - data.X.row(best)).lpNorm<Eigen::Infinity>() <= 0.1;
    if (own || ((refine_basin_ || refine_local_) && near)) rows.push_back(i);
  }
  Dataset out;
  out.X.resize(static_cast<Index>(rows.size()), data.dim());
  out.y.resize(out.X.rows());
  for (std::size_t r = 0; r < rows.size(); ++r) {
    out.X.row(static_cast<Index>(r)) = data.X.row(rows[r]);
    out.y(static_cast<Index>(r)) = data.y(rows[r]);
  }
  return out;
}

}  // namespace varbo::bo
