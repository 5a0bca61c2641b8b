#pragma once
// Optional mixin of a region with a convergence ("stall") rule that can also count trials by their cost: bo's
// `failure_model.stall_value` turns it on once trials have failed (docs/failures.md). Found with dynamic_cast,
// like FreshStartRegion, so regions without it need nothing. Its own header: region.hpp is included everywhere.
namespace varbo {

/// A value stall: a trial without a region success whose cost lies within `fraction`·scale of the attempt's best
/// counts as a stall (converged in value), wherever it lies.
struct ValueStall {
  /// 0 = off (the region's own rule only).
  double fraction = 0;
  /// What `fraction` multiplies: |best| of the attempt (Best; depends on where the cost's zero lies), the range
  /// max − min of the attempt's costs (Range) or their standard deviation (Std), both on the costs' own scale.
  /// Recent: the range of the attempt's last 2(d + 1) costs (session 19: offset-free, and unlike Range not set by
  /// the far costs of the attempt's design when costs are heavy-tailed).
  enum class Scale { Best, Range, Std, Recent } scale = Scale::Best;
  /// Only trials that do not improve the attempt's best at all count (a basin polished by tiny improvements is
  /// spared; a trial at or above the best is a stall).
  bool strict = false;
  /// ≥ 0: the rule applies only while the attempt's best lies more than this × scale above the best cost of all
  /// the data (an attempt converging at a worse level than the incumbent is cut; the one holding or approaching it
  /// is polished). < 0 = always.
  double incumbent = -1;
};

class ValueStallRegion {
 public:
  virtual ~ValueStallRegion();
  virtual void set_value_stall(const ValueStall& rule) = 0;
};

}  // namespace varbo
