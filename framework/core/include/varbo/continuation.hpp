#pragma once
// Continuing a finished run offline (Kuindersma 2013, section 5.4.2). After a run's costs are re-weighted, an
// algorithm that learns around one policy can (1) name the local model of the cost distribution it fits around
// that policy, so a policy can be re-selected at a new risk κ without new trials, and (2) write the `algorithm:`
// block of a study that goes on learning from the re-scored trials. `varbo rescore` asks the run's own algorithm
// for this extension (ComponentInfo::extension<RunContinuation>()), else the first loaded algorithm that offers
// it: the offline tools name no algorithm. A plugin offers it with
//   info.extensions.push_back(std::make_shared<MyContinuation>());
#include <string>

#include "varbo/registry.hpp"

namespace varbo {

/// The local model an offline re-selection fits around the learned policy.
struct LocalModelSpec {
  ResolvedComponent critic;     ///< surrogate of the local cost distribution (J̃, r̃)
  ResolvedComponent optimizer;  ///< maximizer of −(J̃ + κ r̃) over the local ball
  double radius = 0;            ///< ε of the ball around the policy, unit cube
  Index min_points = 0;         ///< fit on at least this many nearest trials
};

class RunContinuation : public ComponentExtension {
 public:
  ~RunContinuation() override;
  /// The local model: from `run_options` (the run's validated options of this algorithm) when the run used
  /// this algorithm, else (nullptr) this algorithm's choice for a run of another algorithm.
  virtual LocalModelSpec local_model(const Options* run_options, const Registry& registry) const = 0;
  /// Completes `algorithm` — the run's resolved block when the run used this algorithm, else a map holding only
  /// `type:` — into the block of a study that continues at risk `kappa` from `history_csv` (columns x1..xd in the
  /// unit cube and cost: the re-scored trials), starting at the study's initial_point.
  virtual void continue_from(YAML::Node& algorithm, const std::string& history_csv, double kappa) const = 0;
};

}  // namespace varbo
