#pragma once
// Homoscedastic GP surrogate: constant mean, standardized costs, any Kernel (default Matérn-5/2 ARD), Gaussian noise;
// hyperparameters by maximum a posteriori (log marginal likelihood + log-normal hyperpriors,
// Kuindersma 2013 eq. (13)) with parallel random restarts of a pluggable Optimizer.
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "gp_likelihood.hpp"
#include "varbo/kernel.hpp"
#include "varbo/optimizer.hpp"
#include "varbo/restarts.hpp"
#include "varbo/state.hpp"
#include "varbo/surrogate.hpp"

namespace varbo::gp {

/// Builds the kernel for a dimension (the `kernel:` component; the surrogate learns its dimension from the data).
using KernelMaker = std::function<std::unique_ptr<Kernel>(Index dim)>;

/// One kernel of `kernel_candidates`: its maker, its name (for the report and the saved state) and the noise
/// floor it is fitted with (each kernel keeps its own default floor, default_min_noise_std).
struct KernelCandidate {
  std::string name;
  KernelMaker make;
  double min_noise_std = 1e-6;
};

struct GpSettings {
  KernelMaker kernel;          ///< null: matern52_ard
  // The priors and boxes of lengthscales, signal_std (every Amplitude) and noise_std below reach the kernel as
  // its role defaults (Kernel::set_role_defaults); noise_std's also applies to white-noise kernel terms.
  int restarts = 4;            ///< optimizer runs per fit, the first warm-started from the previous fit
  /// All restarts when N has grown by this factor since the last such fit (and always up to N = 20); in
  /// between only the warm start runs. ≤ 1: every fit runs all restarts. With the trust-region default of `bo`,
  /// 1.25 kept the plain default's regret on the README's problems (seeds 1–20) for less time per iteration; with
  /// the whole box and a final exploitation phase it had lost Ackley-5 (docs/defaults.md).
  double full_fit_growth = 1.25;
  /// The constant prior mean where no data are: the data mean, or the largest cost seen (a pessimistic
  /// mean, De Ath, Fieldsend & Everson 2020, "What do you mean? The role of the mean function in Bayesian
  /// optimisation": unexplored regions then look no better than the worst trial, so EI refines rather than
  /// visiting every corner of the box; docs/defaults.md).
  enum class PriorMean { DataMean, Max };
  PriorMean prior_mean = PriorMean::DataMean;
  HyperPriors priors;          ///< on ℓ (unit cube) and σ_f, σ_n relative to the standard deviation of y
  // Box of the fit in natural units; σ bounds are relative to the standard deviation of y.
  double min_lengthscale = 0.01, max_lengthscale = 50.0;
  double min_signal_std = 0.05, max_signal_std = 20.0;
  // Floor 1e-6: the fitted noise of deterministic costs sits on the floor, and 1e-4 capped Hartmann-6's regret at
  // ~2e-5 (README); robust_cholesky's jitter keeps duplicated points factorizable.
  // The `gp` component lowers the floor to kSeArdMinNoiseStd for `kernel: se_ard` when min_noise_std is not given.
  double min_noise_std = 1e-6, max_noise_std = 2.0;
  /// Empty: `kernel` alone. Otherwise (≥ 2 kernels with the same hyperparameter names) each fit with all restarts
  /// fits every candidate and keeps the one with the highest fit objective (gp_kernel_choice.cpp); warm-only
  /// refits keep the chosen one. `kernel` and `min_noise_std` then follow the chosen candidate.
  std::vector<KernelCandidate> kernel_candidates;
  /// The first candidate whose fit objective is within this of the best is chosen (0: the best; 3: `kernel: auto`
  /// keeps Matérn-5/2 unless SE-ARD is e^3 ≈ 20 times more probable, docs/defaults.md).
  double kernel_choice_margin = 3.0;
  /// > 0: before each fit, the noise std's upper bound is lowered to near_pair_noise_bound(X, y, this) (a
  /// one-sided test at this level on the costs of the nearest pairs of points, noise_bound.hpp), so that a fit
  /// cannot explain as noise what near pairs show is not noise (Ackley's ripples); real noise is capped below its
  /// size with probability at most this level. 0: off.
  double noise_test_level = 0.0;
  /// With noise_test_level: when the bound shows no noise at all (≤ kNoNoiseBound·std(y), e.g. exact replicates of
  /// a deterministic cost), fit under the tight noise prior kTightNoisePrior (session se13's, starts drawn from it)
  /// instead of capping the noise at the bound; otherwise the cap as without it.
  bool noise_test_tight = false;
};

/// noise_test_tight: the bound (relative to std(y)) below which the data show no noise; the threshold at which
/// `bo` treats a model as deterministic (recommender.cpp).
inline constexpr double kNoNoiseBound = 1e-5;
/// noise_test_tight: LogNormal(log 1e-6, 1.5) on the noise std relative to std(y) (session se13's prior).
inline constexpr double kTightNoiseMedian = 1e-6, kTightNoiseSd = 1.5;

/// The default noise floor (relative to std(y)) of the `gp` component with `kernel: se_ard` (gp_component.cpp).
inline constexpr double kSeArdMinNoiseStd = 1e-7;
/// The default noise_test_level of the `gp` component with `kernel: se_ard` (gp_component.cpp): SE-ARD's smooth
/// prior explains a deterministic cost's fine structure (Ackley's ripples) as noise unless the data rule noise out
/// (docs/defaults.md, "Session se15" and "Session 17").
inline constexpr double kSeArdNoiseTestLevel = 1e-3;

class GpSurrogate final : public Surrogate, public ComponentState, public MeanPrediction {
 public:
  GpSurrogate(Index dim, GpSettings settings, std::shared_ptr<const Optimizer> fit_optimizer);

  FitReport fit(const Dataset& data, Rng& rng) override;
  FitReport condition(const Dataset& data) override;
  Prediction predict(const Vec& x, bool with_gradient) const override;
  double predict_mean(const Vec& x) const override;
  double signal_variance() const override;
  Hyperparameters hyperparameters() const override;
  void set_hyperparameters(const Hyperparameters& values) override;
  bool ready() const override { return posterior_.has_value(); }
  bool tests_noise_on_replicates() const override { return settings_.noise_test_level > 0; }
  /// Exact snapshot (gp_state.cpp): log-parameters, flags, and the data and parameters of the posterior.
  std::string save_state() const override;
  void restore_state(const std::string& state) override;

  const GpSettings& settings() const { return settings_; }
  /// Fit box in standardized log space: [kernel θ (log ℓ_1..D, log σ_f for ARD kernels), log σ_n].
  Box log_box(Index dim) const;
  const Kernel& kernel() const { return *kernel_; }
  /// The chosen entry of settings().kernel_candidates (0 without candidates).
  std::size_t kernel_choice() const { return choice_; }
  /// Current log-parameters in standardized units for data with standard deviation `y_scale`.
  Vec log_params(double y_scale) const;

 private:
  struct Standardization {
    double shift = 0;  ///< cost = shift + scale · standardized
    double scale = 1;
    double top = 0;    ///< the largest cost, standardized
  };
  /// The conditioned model, all in standardized units.
  struct Posterior {
    std::shared_ptr<const Kernel> kernel;  ///< with the standardized values of the fit
    double noise_var = 0;
    double mean = 0;             ///< constant prior mean (standardized)
    Mat X;
    Vec alpha;                   ///< (K + σ_n² I)⁻¹ (y − m)
    Eigen::LLT<Mat> llt;
    double log_likelihood = 0;   ///< log N(y_std | m, K + σ_n² I)
    double jitter = 0;
    Standardization stdz;
    Vec log_params;              ///< p it was built with (for exact snapshots)
  };

  static Standardization standardization(const Vec& y);
  double mean_standardized(const Standardization& s) const;
  /// Builds the posterior for log-params p; nullopt when the Cholesky fails even with jitter.
  std::optional<Posterior> build(const Dataset& data, const Standardization& s, const Vec& p) const;
  void store_natural(const Vec& p, const Standardization& s);
  FitReport report_for(const Posterior& post, const Vec& p) const;
  void ensure_dim(Index d);
  /// Makes candidate c the kernel (and its noise floor the fit's), keeping the current values as the warm start.
  void select_kernel(std::size_t c);
  /// The restarts of one fit of the current kernel: start 0 warm, the others from the hyperpriors, start k on
  /// rng.stream(base, k) — the same streams for every candidate (common random numbers), so a candidate's fit
  /// is exactly the fit a gp with that kernel alone makes from the same rng.
  Restarts<OptimizeResult> run_restarts_for(const Dataset& data, const Standardization& s, Index restarts,
                                            const Rng& rng, std::uint64_t base) const;

  Index dim_;
  GpSettings settings_;
  std::shared_ptr<const Optimizer> optimizer_;
  /// Log kernel values in natural units: known ones as stored, unknown ones (amplitudes before the first fit)
  /// at their prior median.
  Vec natural_kernel_log() const;
  double log_scale_of(Index j, double y_scale) const;

  std::unique_ptr<Kernel> kernel_;  ///< the form, with the role defaults of settings_ (values unused)
  // Hyperparameters in natural units (unit cube, cost units): the state that survives between fits.
  Vec kernel_log_;                 ///< log kernel values, natural units
  std::vector<char> kernel_known_; ///< per kernel value: given or fitted (parameters without scale: from the start)
  double log_noise_std_ = 0, mean_ = 0;
  bool noise_known_ = false, mean_fixed_ = false;
  std::optional<Posterior> posterior_;
  std::optional<Dataset> data_;
  Index last_full_fit_n_ = 0;  ///< N at the last fit with all restarts (0: none yet)
  std::size_t choice_ = 0;     ///< index into settings_.kernel_candidates
};

}  // namespace varbo::gp
