// Exact snapshot of sample_polish (varbo/state.hpp): the state of its sampler (hit-and-run keeps its chains
// between calls); empty when the sampler keeps none.
#include "sample_polish.hpp"

namespace varbo {

std::string SamplePolishOptimizer::save_state() const {
  StateMap m;
  if (const ComponentState* s = state_of(sampler_.get())) m.put("sampler", s->save_state());
  return m.text();
}

void SamplePolishOptimizer::restore_state(const std::string& text) {
  const StateMap m = StateMap::parse(text, "sample_polish state");
  if (!m.has("sampler")) return;
  if (ComponentState* s = state_of(sampler_.get())) s->restore_state(m.str("sampler"));
}

}  // namespace varbo
