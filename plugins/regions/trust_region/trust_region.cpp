#include "trust_region.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "varbo/errors.hpp"
#include "varbo/log.hpp"

namespace varbo {

TrustRegion::TrustRegion(Index dim, TrustRegionOptions o)
    : options_(o), box_(Box::unit(dim)), center_(Vec::Constant(dim, 0.5)), length_(o.length_init) {
  if (!(o.length_min > 0 && o.length_min <= o.length_init && o.length_init <= o.length_max))
    throw ConfigError(fmt::format("trust_region: need 0 < length_min <= length_init <= length_max, got {}, {}, {}",
                                  o.length_min, o.length_init, o.length_max));
  // Eriksson et al. 2019, section 2: τ_fail = ceil(max(4/q, d/q)).
  failure_tolerance_ = o.failure_tolerance > 0
                           ? o.failure_tolerance
                           : static_cast<int>(std::ceil(std::max(4.0 / o.batch_size,
                                                                 static_cast<double>(dim) / o.batch_size)));
}

Box TrustRegion::rebuilt_box() const {
  // The box of side L around the centre, clipped to the unit cube (as TuRBO clips to [0, 1]^d).
  Box b = box_;
  b.lower = (center_.array() - 0.5 * length_).max(0.0).matrix();
  b.upper = (center_.array() + 0.5 * length_).min(1.0).matrix();
  return b;
}

void TrustRegion::set_box() { box_ = rebuilt_box(); }

double TrustRegion::side_cap() const { return std::max(side_cap_, options_.length_min); }

void TrustRegion::update(const Surrogate*, const Dataset& data, Rng&) {
  if (data.size() == 0) return;
  if (data.dim() != box_.dim())
    throw InputError(fmt::format("trust_region: data have dimension {}, the region {}", data.dim(), box_.dim()));
  // The points that count: all of them, or (restart_center: new_points) those since the last restart.
  const bool fresh = options_.restart_center == "new_points" && !returned_;
  const Index from = fresh ? std::min(restart_at_, data.size()) : 0;
  Index arg = 0;
  // Forced failures (bo's failure_model.feasible_region) belong to the update that follows them; one that sets the
  // reference below (the design's or a fresh start's first) drops them.
  const int forced_failures = forced_failures_, forced_halvings = forced_halvings_;
  forced_failures_ = forced_halvings_ = 0;
  const bool forced = forced_failures > 0 || forced_halvings > 0;
  // An anchor (bo's follow_probe) is a point of the current fresh attempt although it was observed before it.
  const bool anchored = fresh && anchor_ >= 0 && anchor_ < from;
  if (from == data.size()) {
    // No point since the restart yet: the box is the restart box around the anchor, else the incumbent.
    if (anchored) arg = anchor_;
    else data.y.minCoeff(&arg);
    seen_ = data.size();
    center_ = data.X.row(arg).transpose();
    length_ = std::min(length_, side_cap());
    set_box();
    return;
  }
  double best = data.y.tail(data.size() - from).minCoeff(&arg);
  arg += from;
  if (anchored && data.y(anchor_) <= best) {
    best = data.y(anchor_);
    arg = anchor_;
  }
  if (seen_ == 0 || (fresh && restarts_ > 0 && seen_ == restart_at_)) {
    best_ = best;  // the first update (initial design, or the first point after a restart) sets the reference
  } else if (data.size() > seen_ || forced) {
    if (!forced && best < best_ - options_.improvement * std::abs(best_)) {
      ++successes_;
      failures_ = 0;
      stalls_ = 0;
    } else {
      // A forced failure (failed trials, a step limited by the probability of success) counts as a trial without
      // improvement even if the new best improved; a failed trial adds no point, so it is no stall either.
      failures_ += forced ? forced_failures : 1;
      successes_ = 0;
      // A stall: every new point next to the incumbent (the centre of the previous update).
      // With a value stall rule (value_stall.hpp), also a point that costs as much as the attempt's best.
      bool near = data.size() > seen_;
      const Vec attempt = data.y.tail(data.size() - from);
      const double overall = data.y.minCoeff();
      for (Index i = std::max(seen_, from); i < data.size(); ++i) {
        const bool close = (data.X.row(i).transpose() - center_).lpNorm<Eigen::Infinity>() <= options_.stall_distance;
        near = near && (close || value_stall(value_stall_, data.y(i), best_, attempt, overall,
                                                  2 * (center_.size() + 1)));
      }
      stalls_ = near ? stalls_ + 1 : (options_.stall_count == "consecutive" ? 0 : stalls_);
    }
    best_ = std::min(best_, best);
    if (successes_ >= options_.success_tolerance) {
      length_ = std::min({2.0 * length_, options_.length_max, side_cap()});
      successes_ = 0;
    } else if (failures_ >= failure_tolerance_) {
      // One halving per τ_fail failures: several at once only when failures were forced (bo's feasible_region).
      while (failures_ >= failure_tolerance_) {
        length_ /= 2.0;
        failures_ -= failure_tolerance_;
      }
      if (!forced) failures_ = 0;
    }
    for (int i = 0; i < forced_halvings; ++i) length_ /= 2.0;
    const int stall_tolerance = options_.stall_tolerance == 0 ? failure_tolerance_ : options_.stall_tolerance;
    if (stall_tolerance > 0 && stalls_ >= stall_tolerance && !returned_) {
      log_info("trust_region: {} trials in a row next to the incumbent without improvement: converged there",
               stalls_);
      length_ = 0;  // restart below
    }
    if (length_ < options_.length_min && returned_) {
      length_ = options_.length_min;  // refining the incumbent at the end of the budget: no restart any more
    } else if (length_ < options_.length_min) {
      ++restarts_;
      log_info("trust_region: side length {:.3g} < {:.3g}: restart {} ({})", length_, options_.length_min,
               restarts_, fresh ? "a fresh start: new design, model of the new points" : "L reset, data kept");
      length_ = fresh ? options_.length_init : options_.restart_length;
      successes_ = failures_ = stalls_ = 0;
      anchor_ = -1;
      if (fresh) {
        restart_at_ = data.size();
        data.y.minCoeff(&arg);
      }
    }
  }
  seen_ = data.size();
  center_ = data.X.row(arg).transpose();
  length_ = std::min(length_, side_cap());  // a cap set since the last update, or restart_length above it
  set_box();
}

bool TrustRegion::value_stall(const ValueStall& rule, double y, double best, const Vec& attempt, double overall,
                              Index window) {
  if (!(rule.fraction > 0) || attempt.size() == 0) return false;
  double scale = std::abs(best);
  if (rule.scale == ValueStall::Scale::Range) {
    scale = attempt.maxCoeff() - attempt.minCoeff();
  } else if (rule.scale == ValueStall::Scale::Recent) {
    const Vec recent = attempt.tail(window > 0 ? std::min(window, attempt.size()) : attempt.size());
    scale = recent.maxCoeff() - recent.minCoeff();
  } else if (rule.scale == ValueStall::Scale::Std) {
    const double mean = attempt.mean();
    const double n = static_cast<double>(attempt.size());
    scale = attempt.size() > 1 ? std::sqrt((attempt.array() - mean).square().sum() / (n - 1)) : 0.0;
  }
  const double tolerance = rule.fraction * scale;
  // (c) An attempt at (or approaching) the incumbent's level is polished: the rule is off while its best is within
  // incumbent·scale of the best cost of all the data (the first attempt always holds it).
  if (rule.incumbent >= 0 && attempt.minCoeff() <= overall + rule.incumbent * scale) return false;
  // (b) strict: a trial that improves the best at all is progress, however small.
  if (rule.strict && y < best) return false;
  return std::abs(y - best) <= tolerance;
}

void TrustRegion::return_to_incumbent() {
  if (returned_) return;
  returned_ = true;
  anchor_ = -1;
  if (restarts_ == 0) return;  // never left the incumbent
  // Refine the incumbent's basin in a small box; the next update re-centres it on the best of all the data and
  // sets the reference (seen_ = 0), as after the initial design.
  restart_at_ = 0;
  seen_ = 0;
  successes_ = failures_ = stalls_ = 0;
  length_ = std::max(0.25 * options_.length_init, options_.length_min);
}

Mat TrustRegion::seeds() const { return center_.transpose(); }

std::string TrustRegion::state() const {
  return fmt::format("L {:.4g}, successes {}/{}, failures {}/{}, restarts {}", length_, successes_,
                     options_.success_tolerance, failures_, failure_tolerance_, restarts_);
}

}  // namespace varbo
