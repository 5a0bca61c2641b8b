// Study::verify (`varbo study verify`): the whole study replayed on a fresh algorithm, every serial trial's
// point and every saved algorithm state compared with the replay; the first divergence reported.
#include <fmt/format.h>

#include "study_impl.hpp"
#include "varbo/csv.hpp"
#include "varbo/errors.hpp"
#include "varbo/state.hpp"

namespace varbo {

using study_detail::kReplayTolerance;
using study_detail::observation_of;

namespace {

std::string join_numbers(const Vec& v) {
  std::string s = "[";
  for (Index i = 0; i < v.size(); ++i) s += (i ? ", " : "") + exact(v[i]);
  return s + "]";
}

std::string first_difference(const std::string& stored, const std::string& replayed) {
  std::size_t i = 0;
  while (i < stored.size() && i < replayed.size() && stored[i] == replayed[i]) ++i;
  const std::size_t from = i > 40 ? i - 40 : 0;
  return fmt::format("at character {}: stored '…{}…' vs replayed '…{}…'", i, stored.substr(from, 100),
                     replayed.substr(from, 100));
}

}  // namespace

VerifyReport Study::verify() {
  Impl& m = live();
  VerifyReport rep;
  std::unique_ptr<Algorithm> alg = m.make_algorithm();
  const auto* resumable = dynamic_cast<const AlgorithmState*>(alg.get());
  const std::vector<TrialRecord> finished = m.store->finished_since(0);
  // A failure taken back (varbo retract) changed the history the algorithm is rebuilt from: the stored trials after
  // it were asked by an algorithm that had been told it, so no replay reproduces them. Said, not compared.
  for (const TrialRecord& t : finished)
    if (retracted(t)) {
      rep.divergence = fmt::format("trial {}'s failure was taken back (varbo retract): the trials after it were asked "
                                   "by an algorithm told that failure, so a replay cannot reproduce them; nothing "
                                   "compared",
                                   t.id);
      return rep;
    }
  const std::vector<AlgorithmSnapshot> states = m.store->algorithm_states();
  // A state saved by an earlier version may write the same values in another form (a list per vector before
  // vectors became one scalar): what counts is the state it restores, so it is compared as this version saves it.
  auto as_saved_now = [&](const AlgorithmSnapshot& s) -> std::optional<std::string> {
    try {
      std::unique_ptr<Algorithm> fresh = m.make_algorithm();
      auto* r = dynamic_cast<AlgorithmState*>(fresh.get());
      if (!r || s.finished > static_cast<std::int64_t>(finished.size())) return std::nullopt;
      r->restore_state(s.state, Impl::observations_of(finished, static_cast<std::size_t>(s.finished)));
      return r->save_state();
    } catch (const Error&) {
      return std::nullopt;
    }
  };
  auto compare = [&](std::int64_t told, std::int64_t outstanding) {
    if (!resumable) return true;
    for (const auto& s : states) {
      if (s.finished != told || s.outstanding != outstanding) continue;
      const std::optional<std::string> now = resumable->save_state();
      ++rep.states_compared;
      if (now && *now == s.state) continue;
      if (now && as_saved_now(s) == now) continue;
      rep.divergence = fmt::format("the saved algorithm state after {} result(s){} differs from the replayed one {}",
                                   told, outstanding >= 0 ? fmt::format(" and the ask of trial {}", outstanding) : "",
                                   now ? first_difference(s.state, *now) : "(the replayed algorithm saves none)");
      return false;
    }
    return true;
  };
  if (!compare(0, -1)) return rep;
  for (std::size_t i = 0; i < finished.size(); ++i) {
    const TrialRecord& t = finished[i];
    const std::vector<Suggestion> s = alg->ask(1);
    ++rep.replayed;
    const bool serial =
        t.batch_size == 1 && t.pending_before == 0 && t.finished_before == static_cast<std::int64_t>(i);
    if (serial) {
      const bool same = s.size() == 1 && s[0].x.size() == t.x.size() &&
                        (m.trial_x(s[0].x) - t.x).cwiseAbs().maxCoeff() <= kReplayTolerance;
      if (!same) {
        const std::string replayed = s.empty() ? std::string("nothing") : join_numbers(m.theta_of(m.trial_x(s[0].x)));
        rep.divergence = fmt::format(
            "trial {} (result {} in finish order): the replay suggests {} instead of the stored {}", t.id, i, replayed,
            join_numbers(t.theta));
        // Equal in user units, different where they are compared (the unit cube): say both, not "[a, b] instead of [a, b]".
        if (!s.empty() && replayed == join_numbers(t.theta))
          rep.divergence += fmt::format(" (in the unit cube: {} against the stored {})", join_numbers(m.trial_x(s[0].x)),
                                        join_numbers(t.x));
        return rep;
      }
    }
    if (!compare(static_cast<std::int64_t>(i), t.id)) return rep;
    alg->tell({observation_of(t)});
    if (!compare(static_cast<std::int64_t>(i) + 1, -1)) return rep;
  }
  return rep;
}
}  // namespace varbo
