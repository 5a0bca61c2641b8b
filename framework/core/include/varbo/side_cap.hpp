#pragma once
// Optional mixin of a region whose size an algorithm may cap for a while: bo's `failure_model.length_max` keeps a
// trust region's side at most 0.8 once trials have failed (docs/failures.md, item 14). Found with dynamic_cast,
// like FreshStartRegion and ValueStallRegion, so regions without it need nothing.
namespace varbo {

class SideCapRegion {
 public:
  virtual ~SideCapRegion();
  /// The largest side (unit cube) the region's box may have from its next update on, below the region's own
  /// limit; +inf = the region's own limit only. Not part of a region's saved state: the algorithm sets it before
  /// every update.
  virtual void set_side_cap(double side) = 0;
};

}  // namespace varbo
