#pragma once
// The thing being optimized: a cost of θ (user units), possibly noisy, possibly failing.
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>
#include "varbo/types.hpp"

namespace varbo {

struct Domain {
  Box box;                         ///< user units
  std::vector<std::string> names;  ///< one per dimension
};

using Components = std::vector<std::pair<std::string, double>>;

/// Result of one trial. A failed trial (ok = false) is recorded, never a crash.
struct Evaluation {
  double cost = 0;
  Components components;  ///< named cost components (their weighted sum is the cost)
  bool ok = true;
  std::string error;
  /// The cost without observation noise, when the task knows it (synthetic benchmarks); NaN otherwise.
  /// Used for simple regret only, never shown to the algorithm.
  double noiseless_cost = std::numeric_limits<double>::quiet_NaN();
};

struct Optimum {
  double cost = 0;
  std::vector<Vec> thetas;  ///< user units
};

/// Threads: the runner calls evaluate() (and noiseless_cost()) on one thread, one trial after another: a Task
/// instance is never entered concurrently, so evaluate() may keep state (a simulator, a device handle, a
/// counter) without locks. Parallel trials are separate processes (`varbo study` workers, docs/studies.md),
/// each with its own instance. A failure is reported as Evaluation{ok = false, error}; an exception thrown by
/// evaluate() is also recorded as a failed trial (its what() as the reason), never a crash. A task that stops
/// because varbo was asked to stop (interrupt.hpp) throws varbo::Interrupted: that trial has no result and is
/// recorded abandoned (suggested again on resume), while one that failed on its own stays failed.
class Task {
 public:
  virtual ~Task();
  virtual Domain domain() const = 0;
  /// Evaluates θ (user units). `rng` is this trial's own stream (noise, random initial states).
  virtual Evaluation evaluate(const Vec& theta, Rng& rng) = 0;
  virtual std::optional<Optimum> optimum() const { return std::nullopt; }
  /// An initial policy θ0 (user units), for cautious methods that start from a known policy.
  virtual std::optional<Vec> initial_point() const { return std::nullopt; }
  virtual std::vector<std::string> component_names() const { return {}; }
  /// The cost at θ (user units) without observation noise, when the task knows it (synthetic benchmarks),
  /// computed without counting as a trial: used to score the *recommended* θ (regret_recommended in
  /// summary.json), never shown to the algorithm. nullopt when unknown (real experiments).
  virtual std::optional<double> noiseless_cost(const Vec& theta) const {
    (void)theta;
    return std::nullopt;
  }
};

/// Optional interface (found with dynamic_cast, as SpaceAware) of a task that hands the trial's number to what it
/// runs: the runner says which trial the next evaluate() is. `trial` is the row of trials.csv (`varbo run`; a
/// worker has no row and passes the id), `id` the study's trial id (`varbo status`, `export`): both continue
/// over a resumed run, and ids are distinct across the workers of a study. Before, the external task counted its
/// own evaluations from 0 in every process, so a resumed run or a second worker sent "trial": 0 again and a
/// script naming its recordings by it overwrote earlier ones.
class TrialAware {
 public:
  virtual ~TrialAware();
  virtual void set_next_trial(long trial, long id) = 0;
};

}  // namespace varbo
