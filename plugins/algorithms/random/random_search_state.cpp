// Snapshot of random search (varbo/state.hpp): the position in the sample sequence; the data come back
// through the history.
#include <fmt/format.h>

#include "random_search.hpp"
#include "varbo/errors.hpp"

namespace varbo::random_search {

std::optional<std::string> RandomSearch::save_state() const {
  if (skip_ != 0) return std::nullopt;  // saved only between serial steps
  StateMap m;
  m.put_int("next", next_);
  m.put_int("skipped", skipped_);
  return m.text();
}

void RandomSearch::restore_state(const std::string& text, const std::vector<Observation>& history) {
  const StateMap m = StateMap::parse(text, "random state");
  const long long next = m.integer("next");
  const long long skipped = m.has("skipped") ? m.integer("skipped") : 0;  // states before session 23 have none
  if (skipped < 0)
    throw InputError(fmt::format("random state: skipped count {} out of range", skipped));
  if (next < 0 || next > budget_ + skipped)
    throw InputError(fmt::format("random state: sample counter {} out of range", next));
  tell(history);
  next_ = static_cast<Index>(next);
  skipped_ = static_cast<Index>(skipped);
}

}  // namespace varbo::random_search
