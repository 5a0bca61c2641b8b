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
  return m.text();
}

void RandomSearch::restore_state(const std::string& text, const std::vector<Observation>& history) {
  const StateMap m = StateMap::parse(text, "random state");
  const long long next = m.integer("next");
  if (next < 0 || next > budget_) throw InputError(fmt::format("random state: sample counter {} out of range", next));
  tell(history);
  next_ = static_cast<Index>(next);
}

}  // namespace varbo::random_search
