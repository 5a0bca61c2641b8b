// How varbo::Study brings its algorithm up to date (docs/studies.md, "How the algorithm is rebuilt"): from the
// saved state that reaches furthest into the finished trials (when the algorithm offers AlgorithmState,
// varbo/state.hpp), then a replay (ask(1), tell) of the trials finished since; a saved state after every change.
#include <fmt/format.h>

#include <algorithm>
#include <cstdlib>
#include <new>

#include "plugin_code.hpp"
#include "study_impl.hpp"
#include "varbo/errors.hpp"
#include "varbo/log.hpp"
#include "varbo/state.hpp"
#include "varbo/text.hpp"

namespace varbo {

using study_detail::kReplayTolerance;
using study_detail::observation_of;

std::vector<Observation> Study::Impl::observations_of(const std::vector<TrialRecord>& trials, std::size_t n) {
  std::vector<Observation> out;
  // A failed trial taken back (varbo retract) was not told to the algorithm that saved a later state.
  for (std::size_t i = 0; i < n; ++i)
    if (!retracted(trials[i])) out.push_back(observation_of(trials[i]));
  return out;
}

const AlgorithmSnapshot* Study::Impl::best_state(const std::vector<AlgorithmSnapshot>& states,
                                                  const std::vector<TrialRecord>& finished, std::int64_t& best_reach) const {
  const AlgorithmSnapshot* best = nullptr;
  best_reach = 0;
  const auto n = static_cast<std::int64_t>(finished.size());
  // States saved before a failure was taken back (varbo retract) hold it: the algorithm is rebuilt without them.
  const std::optional<std::string> retracted_at = store->meta(kRetractedAtKey);
  const double since = retracted_at ? std::strtod(retracted_at->c_str(), nullptr) : 0.0;
  for (const auto& s : states) {
    if (s.finished > n) continue;
    if (s.created_at < since) continue;
    std::int64_t reach = s.finished;
    if (s.outstanding >= 0) {
      // Usable only when that trial was the next to finish: it is then told without a new fit.
      if (s.finished >= n || finished[static_cast<std::size_t>(s.finished)].id != s.outstanding) continue;
      ++reach;
    }
    // Newest first; at equal reach a state after a result (nothing to tell) before one after an ask.
    if (!best || reach > best_reach || (reach == best_reach && best->outstanding >= 0 && s.outstanding < 0)) {
      best = &s;
      best_reach = reach;
    }
  }
  return best;
}

std::optional<std::vector<TrialRecord>> Study::Impl::rebuild() {
  alg = make_algorithm();
  told_ids.clear();
  outstanding.reset();
  dirty = false;
  past_retracted = false;
  retracted_seen = store->meta(kRetractedAtKey).value_or("");
  auto* resumable = dynamic_cast<AlgorithmState*>(alg.get());
  if (!resumable) return std::nullopt;
  std::vector<TrialRecord> finished = checked(store->finished_since(0));
  const std::vector<AlgorithmSnapshot> states = store->algorithm_states();
  std::int64_t reach = 0;
  const AlgorithmSnapshot* best = best_state(states, finished, reach);
  saved_reach = std::max(saved_reach, reach);
  if (!best) return finished;
  const auto m = static_cast<std::size_t>(best->finished);
  // Whatever a (plugin's) restore_state throws, the replay can rebuild the algorithm: a std::stod's
  // invalid_argument made every resume fail (red team, session 28).
  const std::string why = detail::what_it_threw<std::bad_alloc>(
      [&] { resumable->restore_state(best->state, observations_of(finished, m)); });
  if (!why.empty()) {
    // Name the component whose code threw (a plugin's, usually), with its library (red team, session 31).
    const auto* info = config.algorithm.info;
    log_warn("{}: the saved state of algorithm '{}'{} after {} trials cannot be used ({}); replaying the study "
             "instead",
             store->location(), info ? info->full_name() : std::string("?"),
             info && !info->library.empty() ? " (" + info->library + ")" : std::string(), m, why);
    alg = make_algorithm();
    return finished;
  }
  for (std::size_t i = 0; i < m; ++i) told_ids.push_back(finished[i].id);
  if (best->outstanding >= 0) outstanding = best->outstanding;
  return finished;
}

std::vector<TrialRecord> Study::Impl::untold(std::optional<std::vector<TrialRecord>>&& all) const {
  const auto told = static_cast<std::int64_t>(told_ids.size());
  if (!all) return checked(store->finished_since(told));
  // finished_since(told): those with finish_seq >= told, `all` being sorted by finish_seq.
  all->erase(all->begin(), std::partition_point(all->begin(), all->end(),
                                                [&](const TrialRecord& t) { return t.finish_seq < told; }));
  return std::move(*all);
}

bool Study::Impl::saved_state_is_further() const {
  if (!dynamic_cast<const AlgorithmState*>(alg.get())) return false;
  if (store->next_finish_seq() <= static_cast<std::int64_t>(told_ids.size()) + 1) return false;
  const std::vector<TrialRecord> finished = store->finished_since(0);
  std::int64_t reach = 0;
  best_state(store->algorithm_states(), finished, reach);
  return reach > static_cast<std::int64_t>(told_ids.size()) + 1;
}

bool Study::Impl::state_to_save(std::optional<std::int64_t> asked_for) const {
  if (!alg || !dynamic_cast<const AlgorithmState*>(alg.get())) return false;
  return static_cast<std::int64_t>(told_ids.size()) + (asked_for ? 1 : 0) > saved_reach;
}

void Study::Impl::save_state(std::optional<std::int64_t> asked_for) {
  if (!state_to_save(asked_for)) return;
  auto* resumable = dynamic_cast<const AlgorithmState*>(alg.get());
  const auto told = static_cast<std::int64_t>(told_ids.size());
  const std::int64_t reach = told + (asked_for ? 1 : 0);
  // A state that cannot be saved costs the next process a replay, never this suggestion or result (a plugin's
  // `throw 8;` ended every run with exit 3; red team, session 28).
  const std::string why = detail::what_it_threw([&] {
    const std::optional<std::string> text = resumable->save_state();
    if (!text) return;
    AlgorithmSnapshot s;
    s.finished = told;
    s.outstanding = asked_for.value_or(-1);
    s.state = *text;
    s.created_at = unix_time();
    store->add_algorithm_state(s);
    saved_reach = reach;
  });
  if (!why.empty()) say_state_not_saved(told, why);
}

void Study::Impl::say_state_not_saved(std::int64_t told, const std::string& why) {
  saved_reach = std::max<std::int64_t>(saved_reach, told);  // not retried for the same results
  if (save_failure_said) {
    log_debug("{}: the algorithm state after {} result(s) was not saved ({})", store->location(), told, why);
    return;
  }
  save_failure_said = true;
  log_warn("{}: the algorithm state after {} result(s) was not saved ({}); the next process replays the study "
           "instead (said once)",
           store->location(), told, why);
}

void Study::Impl::replay_one(const TrialRecord& t) {
  if (retracted(t)) {  // taken back (varbo retract): counted as told, never told
    told_ids.push_back(t.id);
    past_retracted = true;
    return;
  }
  ++replayed;
  const InfoAsDebug quiet;  // the replayed trial's own lines were said when it was asked
  std::vector<Suggestion> s = alg->ask(1);
  const bool serial = t.batch_size == 1 && t.pending_before == 0 &&
                      t.finished_before == static_cast<std::int64_t>(told_ids.size());
  if (serial) {
    const bool same = s.size() == 1 && s[0].x.size() == t.x.size() &&
                      (trial_x(s[0].x) - t.x).cwiseAbs().maxCoeff() <= kReplayTolerance;
    if (!same && !past_retracted) {  // after a failure taken back the points differ, as they should
      ++mismatches;
      log_warn("{}: replaying trial {}: the algorithm now suggests a different point than it did (is the run "
               "deterministic? same plugins?); continuing with the stored result",
               store->location(), t.id);
    }
  }
  alg->tell({observation_of(t)});
  told_ids.push_back(t.id);
}

void Study::Impl::sync() {
  std::optional<std::vector<TrialRecord>> read;
  // A retraction by another process (varbo retract, another Study object) changed the history: rebuild.
  if (alg && !dirty && store->meta(kRetractedAtKey).value_or("") != retracted_seen) dirty = true;
  if (!alg || dirty || saved_state_is_further()) read = rebuild();
  std::vector<TrialRecord> fresh = untold(std::move(read));
  std::size_t i = 0;
  if (outstanding) {
    if (!fresh.empty() && fresh[0].id == *outstanding) {
      alg->tell({observation_of(fresh[0])});
      told_ids.push_back(fresh[0].id);
      outstanding.reset();
      i = 1;
    } else {
      // The trial this object asked for did not finish next: the state after that ask is not the canonical
      // one (results told in finish order); start again from the saved states.
      fresh = untold(rebuild());
      if (outstanding) {  // a saved state that had asked for exactly the next trial to finish
        alg->tell({observation_of(fresh[0])});
        told_ids.push_back(fresh[0].id);
        outstanding.reset();
        i = 1;
      }
    }
  }
  for (; i < fresh.size(); ++i) replay_one(fresh[i]);
}

}  // namespace varbo
