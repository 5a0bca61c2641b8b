#pragma once
// TuRBO-1's trust region (Eriksson et al. 2019, section 2): a box of side L around the incumbent, doubled
// after τ_succ consecutive successes, halved after τ_fail consecutive failures, and restarted when L < L_min or
// when the search has converged next to the incumbent (2 stalls in a row). A restart is TuRBO's fresh start by
// default (`restart_center: new_points`; FreshStartRegion: the algorithm draws a new design, models the new
// points, and refines the incumbent of all the data in its last trials); `restart_center: incumbent` keeps the
// incumbent and the data instead (docs/defaults.md).
// It is a plain box region (no constraint), so every optimizer can search it.
#include <limits>
#include <string>

#include "varbo/region.hpp"
#include "varbo/side_cap.hpp"
#include "varbo/state.hpp"
#include "varbo/value_stall.hpp"

namespace varbo {

struct TrustRegionOptions {
  double length_init = 0.8;                 ///< Eriksson 2019: L_init = 0.8
  double length_min = 0.0078125;            ///< 0.5^7
  double length_max = 1.6;
  int success_tolerance = 3;                ///< τ_succ
  int failure_tolerance = 0;                ///< τ_fail; 0 = ceil(max(4/q, d/q))
  int batch_size = 1;                       ///< q, only used for the default τ_fail
  double improvement = 1e-3;                ///< success: new best < old best − improvement·|old best|
  /// With restart_center: incumbent, L after a restart. 2 covers the whole unit cube from any centre, so after a
  /// collapse the search is global until failures shrink it again: restarting at 0.8 around the same incumbent repeated the same collapse
  /// (Branin with SE-ARD, seeds 15 and 19: stuck at (10, 3.0), regret 1.5; docs/defaults.md).
  double restart_length = 2.0;
  /// What a restart does: `incumbent` keeps searching around the best point of all the data with L =
  /// restart_length (the box returns to the basin that collapsed as soon as L shrinks); `new_points` is TuRBO's
  /// fresh start: the algorithm draws a new initial design and models the points since the restart only, and
  /// the box (L = length_init) centres on their best and counts successes against it.
  /// The default since issue 13/11: better on Branin, Hartmann-3 and Hartmann-6 (median 0.06 → 3.6e-4), as good on
  /// Ackley-5, and with bo's refinement excluding (not weighting by) likely failures, as precise next to a failure
  /// region as without one (docs/defaults.md).
  std::string restart_center = "new_points";
  /// A stall: a failure whose new point lies within stall_distance (∞-norm, unit cube) of the incumbent, i.e.
  /// the model has converged there. stall_tolerance consecutive stalls restart the region at once instead of
  /// after the ~7·τ_fail failures that halve L below length_min (Hartmann-6: 31 stalls in a row in a local
  /// minimum; Ackley-5's ripples: at most 3, docs/defaults.md). 0 = τ_fail, −1 = off.
  /// 2 since session h6b (with bo's restart_design: away and refine_model: basin; 3 before): the attempt that
  /// converged hands over 1 trial sooner, which with the other two took Hartmann-6's stuck runs from 4 to 3.
  double stall_distance = 1e-3;
  int stall_tolerance = 2;
  /// `consecutive`: a failure away from the incumbent resets the stall count (EI's probes of the box's corners
  /// between stalls then delay the restart); `since_success`: only a success resets it.
  std::string stall_count = "consecutive";
};

class TrustRegion final : public RegionConstraint, public ComponentState, public FreshStartRegion,
                          public ValueStallRegion, public SideCapRegion {
 public:
  TrustRegion(Index dim, TrustRegionOptions options);
  /// Compares the best cost in `data` with the best at the previous update (only when new points arrived),
  /// updates the counters and L, and re-centres the box on the best observed point. A restart (L < L_min)
  /// resets L and the counters; unlike TuRBO, whose restart discards the data and draws a new design, the
  /// data are kept (the algorithm owns them) and the box re-centres on the incumbent of all the data.
  void update(const Surrogate* model, const Dataset& data, Rng& rng) override;
  const Box& bounds() const override { return box_; }
  Mat seeds() const override;
  std::string state() const override;
  /// Exact snapshot (trust_region_state.cpp): centre, L, best, counters.
  std::string save_state() const override;
  void restore_state(const std::string& state) override;

  double length() const { return length_; }
  int successes() const { return successes_; }
  int failures() const { return failures_; }
  int stalls() const { return stalls_; }
  int restarts() const { return restarts_; }
  /// restart_center: new_points asks the algorithm for a fresh start (new design, model of the new data).
  int fresh_starts() const override { return options_.restart_center == "new_points" ? restarts_ : 0; }
  /// Back to the incumbent of all the data with L = length_init / 4 (a box for refinement), no fresh start after.
  void return_to_incumbent() override;
  /// A value stall rule (value_stall.hpp; bo's failure_model.stall_value, once trials have failed). Not part of
  /// the saved state: bo sets it before every update. Along a flat direction (Hartmann-6's local minimum is flat
  /// in x3) a converged attempt's points differ by ~0.01 in θ and no distance test sees them as next to the
  /// incumbent; their costs do (docs/failures.md).
  void set_value_stall(const ValueStall& rule) override { value_stall_ = rule; }
  /// A cap on L below length_max (side_cap.hpp; bo's failure_model.length_max, once trials have failed): L never
  /// doubles past it, and a larger L shrinks to it at the next update. Not part of the saved state either.
  void set_side_cap(double side) override { side_cap_ = side; }
  /// Whether a trial costing `y` is a value stall for an attempt whose best so far is `best` (before this update),
  /// whose costs are `attempt` and whose data's best overall is `overall` (the rule above; false when off).
  /// `window`: how many of the attempt's last costs Scale::Recent spans (2(d + 1) in use).
  static bool value_stall(const ValueStall& rule, double y, double best, const Vec& attempt, double overall,
                          Index window = 0);
  bool returned() const { return returned_; }
  int failure_tolerance() const { return failure_tolerance_; }
  /// Failures forced on the next update (bo's failure_model.feasible_region, session fail14): that update counts
  /// `forced_failures` trials without improvement, each like TuRBO's τ_fail counter's (a failed trial; a step limited by
  /// the probability of success, even if it improved), and `forced_halvings` halvings of L, then clears both. Set through
  /// the state (keys of the same names, absent when 0), so no interface is needed; an update that sets the reference
  /// (the first after the design or a fresh start) drops them.
  int forced_failures() const { return forced_failures_; }
  int forced_halvings() const { return forced_halvings_; }
  const Vec& center() const { return center_; }
  /// An anchor (bo's failure_model.follow_probe, session fail15): the index of a data point from before the latest
  /// fresh start that counts as a point of the new attempt (its centre while it is the attempt's best), so an
  /// attempt can begin at a successful far probe without a new design. Set through the state (key `anchor`, absent
  /// when there is none); the next restart or return_to_incumbent() drops it. -1 = none.
  Index anchor() const { return anchor_; }

 private:
  void set_box();
  /// The box that centre and length give (set_box's).
  Box rebuilt_box() const;
  /// The side cap in force (set_side_cap), never below length_min: a cap below it would restart the region at
  /// every update.
  double side_cap() const;

  TrustRegionOptions options_;
  int failure_tolerance_;
  Box box_;
  Vec center_;
  double length_;
  double best_ = 0;
  Index seen_ = 0;  ///< data size at the previous update
  Index restart_at_ = 0;  ///< data size at the last restart (restart_center: new_points)
  bool returned_ = false;  ///< return_to_incumbent() was called: no fresh start any more
  int successes_ = 0, failures_ = 0, restarts_ = 0;
  ValueStall value_stall_;
  double side_cap_ = std::numeric_limits<double>::infinity();  ///< see set_side_cap()
  int stalls_ = 0;  ///< consecutive stalls (see TrustRegionOptions::stall_distance)
  int forced_failures_ = 0, forced_halvings_ = 0;  ///< see forced_failures()
  Index anchor_ = -1;  ///< see anchor()
};

}  // namespace varbo
