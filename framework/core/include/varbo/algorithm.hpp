#pragma once
// An optimization algorithm in ask/tell form: it never calls the task itself, so trials can run anywhere.
#include <optional>
#include <string>
#include <vector>
#include "varbo/surrogate.hpp"
#include "varbo/task.hpp"

namespace varbo {

struct Suggestion {
  Vec x;                  ///< unit cube
  std::string phase;      ///< "initial", "ei", "random", ...
  double fit_seconds = 0;
  double acquisition_seconds = 0;
};

struct Observation {
  Vec x;  ///< unit cube
  double cost = 0;
  bool ok = true;
  Components components;
};

/// Per-iteration model information for logs and snapshots.
struct ModelSnapshot {
  Index iteration = 0;
  Hyperparameters hyperparameters;
  double objective = 0;
  std::string note;
  /// The search region's state() after its latest update (e.g. CRBO's cautiousness report); empty if none.
  std::string region_state;
};

/// Threads: every method is called from one thread, never concurrently (an algorithm may use parallel_for
/// inside). Determinism: ask() must depend only on the seed (BuildContext::seed) and the ask/tell sequence,
/// because `--resume` and `varbo study` rebuild an algorithm by replaying its trials (ask(1) then tell(...)).
class Algorithm {
 public:
  virtual ~Algorithm();
  virtual std::vector<Suggestion> ask(Index q = 1) = 0;
  virtual void tell(const std::vector<Observation>& observations) = 0;
  /// Points (unit cube) being evaluated elsewhere whose results are not known yet (other workers of a
  /// study). They hold for every later ask() until replaced; an algorithm that can, avoids suggesting them
  /// again (BO: adds them to its batch fantasies). Default: ignored.
  virtual void set_pending(const std::vector<Vec>& pending) { (void)pending; }
  /// The recommended θ (unit cube), e.g. the evaluated point with the best posterior mean.
  virtual std::optional<Vec> recommendation() const { return std::nullopt; }
  /// The model after the latest fit, if the algorithm has one.
  virtual const Surrogate* model() const { return nullptr; }
  virtual std::optional<ModelSnapshot> snapshot() const { return std::nullopt; }
};

}  // namespace varbo
