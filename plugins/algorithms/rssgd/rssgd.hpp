#pragma once
// Risk-sensitive stochastic gradient descent (Kuindersma 2013, section 4.1, Algorithm 3) in ask/tell form.
// ask() proposes θ + z with z ~ N(0, diag(σ²)); tell() adds the observed cost, refits the critic on the
// observations near θ (ε-ball or k nearest) and applies the update of eq. (19). The risk factor κ may change
// between steps (a schedule of phases, or set_kappa()). The recommendation is the current θ.
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "local_data.hpp"
#include "rssgd_update.hpp"
#include "varbo/registry.hpp"
#include "varbo/state.hpp"

namespace varbo::rssgd {

/// κ for `steps` updates (0 = for the rest of the run).
struct KappaPhase {
  Index steps = 0;
  double kappa = 0;
};

struct Settings {
  Vec sigma;                 ///< per-dimension perturbation std (unit cube); isotropic when all equal
  StepSize step;
  double cost_unit = -1;     ///< what step.min/max refer to (rssgd_update.hpp); -1 = the local costs' std
  double max_step = -1;      ///< largest |Δθ| of one update (unit cube); -1 = the ε-ball's radius, 0 = no limit
  Neighborhood neighborhood;
  double kappa = 0;          ///< used when `schedule` is empty
  std::vector<KappaPhase> schedule;
  bool evaluate_initial = true;  ///< first trial executes θ0 itself (gives the critic a point at θ)
  Index min_fit_points = 3;      ///< fewer local observations: no update, only collect data
};

std::vector<OptionSpec> options();
/// Settings from validated options (dim = problem dimension).
Settings settings_from(const Options& options, Index dim);

class Rssgd final : public Algorithm, public AlgorithmState {
 public:
  /// `start` in the unit cube; `critic` is refit on the local data each step; `history` (may be empty) are
  /// observations known before the run (unit cube), e.g. re-scored trials of an earlier run.
  Rssgd(Settings settings, std::unique_ptr<Surrogate> critic, Vec start, std::uint64_t seed,
        Dataset history = Dataset{});
  std::vector<Suggestion> ask(Index q) override;
  void tell(const std::vector<Observation>& observations) override;
  /// Points handed out by other processes of a study and not yet finished: θ0 and perturbation draws are not
  /// handed out again (each worker of a study ran θ0, then one perturbation each three times; red team, session 27).
  void set_pending(const std::vector<Vec>& pending) override;
  std::optional<Vec> recommendation() const override { return theta_; }
  const Surrogate* model() const override { return critic_ready_ ? critic_.get() : nullptr; }
  std::optional<ModelSnapshot> snapshot() const override;
  /// Exact snapshot (rssgd_state.cpp): θ, the step counters, κ, the critic's state; nullopt when the critic
  /// offers no ComponentState.
  std::optional<std::string> save_state() const override;
  void restore_state(const std::string& state, const std::vector<Observation>& history) override;

  /// Changes κ for every later step (overrides the schedule): variable risk during learning.
  void set_kappa(double kappa);
  /// κ of update number `step` (0-based).
  double kappa_at(Index step) const;
  const Vec& theta() const { return theta_; }
  const Dataset& data() const { return data_; }
  Index updates() const { return updates_; }

 private:
  struct Pending {
    Vec x;
    bool initial = false;
  };
  /// One update from the observation (Algorithm 3, steps d–e); `failed`: a failed trial at o.x, counted as a cost
  /// above every one seen.
  void update_from(const Observation& o, const Pending& p, bool failed = false);

  Settings s_;
  std::unique_ptr<Surrogate> critic_;
  Vec theta_;
  Rng rng_;
  Dataset data_;
  std::deque<Pending> pending_;
  bool asked_initial_ = false;
  bool initial_elsewhere_ = false;  ///< θ0 is pending in another process (set_pending)
  Index pending_elsewhere_ = 0;     ///< perturbations pending in other processes: their stream indices are skipped
  Index perturbations_ = 0;  ///< perturbations asked (stream index of z)
  Index steps_ = 0;          ///< perturbations told (κ schedule position)
  Index updates_ = 0;        ///< updates applied
  bool critic_ready_ = false;
  bool step_limit_warned_ = false;
  double last_fit_seconds_ = 0;
  std::optional<double> kappa_override_;
  Index kappa_override_from_ = 0;
  ModelSnapshot snapshot_;
  bool has_snapshot_ = false;
};

/// Reads a history CSV: columns x1..xd (unit cube) and `cost`. Errors name the file.
Dataset read_history(const std::string& file, Index dim);

}  // namespace varbo::rssgd
