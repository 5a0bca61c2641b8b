// Exact snapshot of the trust region (varbo/state.hpp): what its next update() continues from.
#include "trust_region.hpp"
#include "varbo/errors.hpp"

namespace varbo {

std::string TrustRegion::save_state() const {
  StateMap m;
  m.put("center", center_);
  m.put("length", length_);
  m.put("best", best_);
  m.put_int("seen", seen_);
  m.put_int("successes", successes_);
  m.put_int("failures", failures_);
  m.put_int("restarts", restarts_);
  m.put_int("restart_at", restart_at_);
  m.put("returned", returned_);
  m.put_int("stalls", stalls_);
  if (forced_failures_ > 0) m.put_int("forced_failures", forced_failures_);  // absent when 0: older states unchanged
  if (forced_halvings_ > 0) m.put_int("forced_halvings", forced_halvings_);
  if (anchor_ >= 0) m.put_int("anchor", anchor_);  // absent without one: older states unchanged
  // The box is usually the one centre and length give (set_box), but not before the first update (the whole unit
  // cube) nor right after return_to_incumbent (the last box; L changed): bo draws its random points in it, so a
  // restored region must have this very box (a resumed run drew from [0.1, 0.9]^d where the run drew from [0, 1]^d).
  const Box rebuilt = rebuilt_box();
  if (!(box_.lower == rebuilt.lower && box_.upper == rebuilt.upper)) {
    m.put("box_lower", box_.lower);
    m.put("box_upper", box_.upper);
  }
  return m.text();
}

void TrustRegion::restore_state(const std::string& text) {
  const StateMap m = StateMap::parse(text, "trust_region state");
  const Vec center = m.vec("center");
  if (center.size() != box_.dim()) throw InputError("trust_region state: the centre has the wrong dimension");
  center_ = center;
  length_ = m.real("length");
  best_ = m.real("best");
  seen_ = static_cast<Index>(m.integer("seen"));
  successes_ = static_cast<int>(m.integer("successes"));
  failures_ = static_cast<int>(m.integer("failures"));
  restarts_ = static_cast<int>(m.integer("restarts"));
  restart_at_ = m.has("restart_at") ? static_cast<Index>(m.integer("restart_at")) : 0;  // older snapshots
  returned_ = m.has("returned") && m.boolean("returned");
  stalls_ = m.has("stalls") ? static_cast<int>(m.integer("stalls")) : 0;
  forced_failures_ = m.has("forced_failures") ? static_cast<int>(m.integer("forced_failures")) : 0;
  forced_halvings_ = m.has("forced_halvings") ? static_cast<int>(m.integer("forced_halvings")) : 0;
  anchor_ = m.has("anchor") ? static_cast<Index>(m.integer("anchor")) : -1;
  if (anchor_ < -1) throw InputError("trust_region state: negative anchor");
  if (forced_failures_ < 0 || forced_halvings_ < 0) throw InputError("trust_region state: negative forced failures");
  if (m.has("box_lower") || m.has("box_upper")) {
    Box b = box_;
    b.lower = m.vec("box_lower");
    b.upper = m.vec("box_upper");
    if (b.lower.size() != box_.dim() || b.upper.size() != box_.dim() || !(b.lower.array() <= b.upper.array()).all())
      throw InputError("trust_region state: the box has the wrong dimension or lower > upper");
    box_ = b;
  } else if (seen_ == 0 && restarts_ == 0 && !returned_) {
    box_ = Box::unit(box_.dim());  // a state saved before the first update by a version that did not store the box
  } else {
    set_box();
  }
}

}  // namespace varbo
