#pragma once
// One restart routine for every multi-start local search (the gp and vhgp hyperparameter fits, the
// `multistart` acquisition optimizer): k starts run in parallel, start i on its own random stream, and the
// results are reduced in index order with ties keeping the lower index. Start i's result depends only on i and
// its stream, never on which thread ran it or when, so a seed fixes the result whatever the thread count.
#include <cstddef>
#include <optional>
#include <utility>
#include <vector>

#include "varbo/parallel.hpp"
#include "varbo/types.hpp"

namespace varbo {

/// The results of all starts, in start order, and the winner.
template <class Result>
struct Restarts {
  std::vector<Result> results;
  Index best = -1;    ///< the successful start with the highest score (ties: the lower index); -1 if none
  Index failed = 0;   ///< starts without a score
};

/// The index of the highest score among `results` (score(r): std::optional<double>, nullopt = failed), ties
/// keeping the lower index; `failed` (optional) counts the results without a score.
template <class Result, class Score>
Index best_restart(const std::vector<Result>& results, Score score, Index* failed = nullptr) {
  Index best = -1, n_failed = 0;
  std::optional<double> best_score;
  for (std::size_t k = 0; k < results.size(); ++k) {
    const std::optional<double> s = score(results[k]);
    if (!s) {
      ++n_failed;
      continue;
    }
    if (best < 0 || *s > *best_score) {
      best = static_cast<Index>(k);
      best_score = s;
    }
  }
  if (failed) *failed = n_failed;
  return best;
}

/// Runs start i = 0..n−1 in parallel as run(i, rng_i) → Result, with rng_i = stream_of(i) (a copy the start
/// may advance), and reduces in index order by score (see best_restart). `run` must not throw; it is called
/// concurrently, so it may write only to its own result.
template <class Result, class StreamOf, class Run, class Score>
Restarts<Result> run_restarts(Index n, StreamOf stream_of, Run run, Score score) {
  Restarts<Result> out;
  out.results.resize(static_cast<std::size_t>(n));
  parallel_for(n, [&](Index i) {
    Rng rng = stream_of(i);
    out.results[static_cast<std::size_t>(i)] = run(i, rng);
  });
  out.best = best_restart(out.results, score, &out.failed);
  return out;
}

}  // namespace varbo
