// Exact snapshot of the hit-and-run sampler (varbo/state.hpp): each chain's last point and the previous call's
// samples, which the next call continues from.
#include "hit_and_run.hpp"

namespace varbo {

std::string HitAndRunSampler::save_state() const {
  std::lock_guard<std::mutex> lock(mutex_);
  StateMap m;
  m.put("chains", chains_);
  m.put("previous", previous_);
  return m.text();
}

void HitAndRunSampler::restore_state(const std::string& text) {
  const StateMap m = StateMap::parse(text, "hit_and_run state");
  std::lock_guard<std::mutex> lock(mutex_);
  chains_ = m.rows("chains");
  previous_ = m.mat("previous");
}

}  // namespace varbo
