#pragma once
// The `vhgp` surrogate: a variational heteroscedastic GP of the cost (Kuindersma 2013, section 2.2; eq. 6–7,
// 13). Costs are standardized inside (y_s = (y − m)/s); every reported quantity is in cost units.
#include <memory>
#include <optional>
#include <vector>
#include "varbo/optimizer.hpp"
#include "varbo/state.hpp"
#include "varbo/surrogate.hpp"
#include "gp_surrogate.hpp"
#include "homoscedastic_init.hpp"
#include "vhgp_objective.hpp"

namespace varbo::vhgp {

/// Which member of the model family a fit may end in. The homoscedastic GP is the VHGP with a constant noise
/// process (σ_g → 0, β = 0), so it is a nested model whose bound equals its log marginal likelihood.
enum class NoiseModel {
  Auto,            ///< the heteroscedastic fit unless its bound beats the homoscedastic one by less than the
                   ///< BIC penalty ½ p log N of g's p extra hyperparameters (D + 1 for an ARD kernel)
  Heteroscedastic, ///< always the heteroscedastic fit (the paper's model)
  Homoscedastic,   ///< always the constant-noise member (a GP with the VHGP's f kernel and priors)
};

/// How the constant-noise member is fitted (`noise_model` auto or homoscedastic).
enum class HomoscedasticMember {
  Vhgp,  ///< the vhgp's own homoscedastic fit (its f priors and boxes, its noise prior, 3 lengthscale starts)
  Gp,    ///< a `gp` surrogate (gp::GpSurrogate with its defaults and kernel_f) fitted on the same data with the
         ///< caller's stream; when selected, the vhgp predicts with it (docs/noisy.md, branch vh14)
};

/// The settings of the `vhgp` component. Every default here is the declared default of its option (plugin.cpp binds
/// them with OptionSet, so `--describe`, the YAML and a default-constructed VhgpConfig agree; the kernels, which are
/// components, are declared as matern52_ard and se_ard, the VhgpKernels defaults; kernel_f: auto's candidates are
/// built by the registry, plugin.cpp fills kernel_f_candidates).
struct VhgpConfig {
  VhgpKernels kernels;
  NoiseModel noise_model = NoiseModel::Auto;
  int restarts = 4;  ///< 8 until issue 10's speed work; 4 is the gp's count (neutral on regret, docs/noisy.md)
  bool standardize = true;
  bool warm_start = true;
  bool lambda_warmup = false;  ///< optimize log Λ alone first (the authors' first phase; ~2× the time, rarely better)
  int restart_evaluations = 40;  ///< stage-1 evaluations per start; 0: every start runs to convergence
  int finalists = 2;             ///< starts optimized to convergence after stage 1 (2 keeps both cores busy)
  bool fixed_hyperparameters = false;  ///< fit() optimizes log Λ only, at the given (or default) hyperparameters
  /// A full fit (homoscedastic init + all restarts) when N has grown by this factor since the last one; in
  /// between only the warm start is optimized. ≤ 1: every fit is full.
  double full_fit_growth = 1.25;
  /// Evaluations of the warm start in a fit between full fits; 0: to convergence (docs/noisy.md, study time).
  /// Applies to the joint warm fit (warm_lambda_only false).
  int warm_evaluations = 0;
  /// Report the full-fit counter in state() ("last_full_fit_n"): bo's final recommendation refit then continues
  /// this model's schedule from its exact snapshot (warm-only unless N has grown by full_fit_growth) instead of
  /// a full fit of a fresh model (all restarts; 2–6 s of a 5-s study at N = 100, d = 5; docs/noisy.md).
  bool warm_final_refit = true;
  /// `noise_model: auto` chooses between the noise process and constant noise at every fit (true) or only at
  /// full fits (false): in between, only the family chosen at the last fit is refitted (warm), as the gp keeps
  /// its hyperparameters' basin between full fits. Saves the other family's warm fit (docs/noisy.md).
  bool select_every_fit = false;
  /// A fit between full fits optimizes only log Λ (the variational parameters) at the previous hyperparameters,
  /// as the gp only re-conditions between refits; false: the warm start's joint optimization (docs/noisy.md).
  bool warm_lambda_only = true;
  /// The constant-noise member: the vhgp's own fit or the `gp` surrogate's (HomoscedasticMember).
  /// Default gp since branch vh14 (docs/noisy.md, "the constant-noise member as the gp"): where `auto` finds no
  /// noise process the vhgp is the gp (homoscedastic medians within 2x of the gp's on 6 of 6 problems, not 4).
  HomoscedasticMember homoscedastic_member = HomoscedasticMember::Gp;
  /// The gp member's noise floor relative to std(y) (plugin.cpp: as the `gp` component, 1e-7 for kernel_f se_ard).
  double gp_member_min_noise_std = gp::GpSettings{}.min_noise_std;
  /// `kernel_f: auto` (plugin.cpp): the kernels f may be, as the `gp` component's `kernel: auto` (its
  /// kAutoCandidates, each with its noise floor). The gp member chooses among them at its full fits exactly as a
  /// `gp` does, and the heteroscedastic side takes the member's choice; without a gp member (noise_model
  /// heteroscedastic, homoscedastic_member vhgp) f is the first. Empty: kernels.f alone.
  std::vector<gp::KernelCandidate> kernel_f_candidates;
  VhgpHyperprior prior;
};

class VhgpSurrogate final : public Surrogate, public ComponentState, public MeanPrediction {
 public:
  /// `gp_optimizer`: the gp member's fit optimizer (homoscedastic_member: gp; the `gp` component's default
  /// fit_optimizer in the plugin); null: `fit_optimizer`.
  VhgpSurrogate(Index dim, VhgpConfig config, std::shared_ptr<const Optimizer> fit_optimizer,
                std::shared_ptr<const Optimizer> gp_optimizer = nullptr);

  FitReport fit(const Dataset& data, Rng& rng) override;
  FitReport condition(const Dataset& data) override;
  Prediction predict(const Vec& x, bool with_gradient) const override;
  /// The gp member's mean alone when it is the selected model; else predict()'s.
  double predict_mean(const Vec& x) const override;
  double signal_variance() const override;
  Hyperparameters hyperparameters() const override;
  void set_hyperparameters(const Hyperparameters& values) override;
  std::vector<std::pair<std::string, Vec>> state() const override;
  void set_state(const std::string& name, const Vec& value) override;
  bool ready() const override { return posterior_ != nullptr; }
  /// Exact snapshot (vhgp_state.cpp): the warm starts of the next fit, the full-fit counter, and the posterior
  /// as (data, model-unit parameters), rebuilt by the same deterministic conditioning.
  std::string save_state() const override;
  void restore_state(const std::string& state) override;

  /// The bound F in cost units at the current parameters (valid after fit/condition).
  double bound() const { return bound_; }
  /// The predictive of the latent quantities in model (standardized) units, for tests.
  LatentPrediction predict_latent(const Vec& x, bool with_gradient) const;
  const VhgpConfig& config() const { return config_; }
  /// The kernels of f and g with the VHGP's priors and boxes (parameter tables in the order of θ_f and θ_g).
  const Kernel& f_form() const { return *f_form_; }
  const Kernel& g_form() const { return *g_form_; }
  /// The last fit ended in the constant-noise member (noise_model auto or homoscedastic).
  bool homoscedastic_selected() const { return homoscedastic_selected_; }
  /// The selected constant-noise member is the gp member (homoscedastic_member: gp): predict() is its predict().
  bool gp_member_selected() const { return gp_selected_; }
  /// The gp member (null unless homoscedastic_member: gp), for tests.
  const gp::GpSurrogate* gp_member() const { return gp_member_.get(); }
  /// The entry of config().kernel_f_candidates f uses (0 without candidates): the gp member's choice at its last
  /// full fit.
  std::size_t kernel_f_choice() const { return f_choice_; }

 private:
  /// Parameters in cost units (the canonical state): θ_f with log σ_f of costs, μ0 the log noise variance of
  /// costs; log Λ is the same in both unit systems.
  struct CostParams {
    Vec theta_f, theta_g, log_lambda;
    double mu0 = 0;
  };
  struct Scaling {
    double mean = 0, scale = 1;
  };
  Scaling scaling_for(const Vec& y) const;
  VhgpParams to_model(const CostParams& c, Index n, const Scaling& s) const;
  CostParams to_cost(const VhgpParams& p, const Scaling& s) const;
  /// Default hyperparameters when neither given nor fitted (cost units).
  CostParams defaults(const Scaling& s) const;
  FitReport condition_at(const Dataset& data, const VhgpParams& params, const Scaling& s, FitReport report);
  /// The constant-noise member of the family at the homoscedastic fit `x` = [θ_f ; log σ_n] (model units):
  /// σ_g at its lower bound, β = 0 (log Λ = log ½), μ0 = log σ_n²; g's lengthscales from `like` (irrelevant).
  VhgpParams homoscedastic_member(const Vec& x, const VhgpParams& like, Index n) const;

  /// The starts of the heteroscedastic restarts (model units): the warm start when `warm`; on a full fit the GP
  /// start from `homo` and `restarts` in all.
  std::vector<VhgpParams> restart_starts(Index n, const Scaling& s, const HomoscedasticFit& homo, bool warm, bool full,
                                         const Rng& base) const;
  /// A start of a restart: θ_f moved, θ_g and μ0 drawn around `gp_start` (model units).
  VhgpParams perturbed(const VhgpParams& gp_start, Rng& r) const;
  /// Makes candidate `c` of kernel_f_candidates the kernel of f: config_.kernels.f, f_form_ and f_scaling_. The
  /// candidates have the same hyperparameter names (the `gp` component's rule), so every θ_f kept (warm starts,
  /// given values) is laid out for either.
  void use_f_kernel(std::size_t c);

  Index dim_;
  VhgpConfig config_;
  std::shared_ptr<const Optimizer> optimizer_;
  std::shared_ptr<const Kernel> f_form_, g_form_;  ///< configured with config_.prior (VhgpHyperprior::configured)
  Vec f_scaling_;  ///< output_scaling(f): which log θ_f shift by log(scale) between cost and model units
  std::optional<CostParams> params_;  ///< given or fitted hyperparameters (cost units)
  bool lambda_fitted_ = false;        ///< params_'s log Λ came from a fit (not given through set_state)
  Vec bound_gradient_;  ///< ∂F at the parameters of the last condition() (model units), for inspection
  Scaling scaling_;
  std::shared_ptr<const VhgpPosterior> posterior_;
  double bound_ = 0;
  std::optional<Dataset> posterior_data_;  ///< the data posterior_ was conditioned on (for exact snapshots)
  Vec posterior_params_;                   ///< and its parameters in model units, packed (VhgpParams::pack)
  Index last_full_fit_n_ = 0;  ///< N at the last full fit (0: none yet)
  /// The best heteroscedastic solution of the last fit (cost units): the warm start of the next one, also when
  /// the homoscedastic member was selected (whose σ_g at its bound is a poor start).
  std::optional<CostParams> heteroscedastic_;
  /// The last homoscedastic fit [θ_f (log σ_f of costs) ; log σ_n of costs]: its warm start.
  Vec homoscedastic_;
  bool homoscedastic_selected_ = false;
  /// homoscedastic_member: gp — the `gp` surrogate fitted at every fit (its own warm starts and schedule), and
  /// whether the last fit selected it (then predictions and signal_variance are its).
  std::unique_ptr<gp::GpSurrogate> gp_member_;
  bool gp_selected_ = false;
  std::size_t f_choice_ = 0;  ///< kernel_f_candidates entry of f_form_ (and of posterior_)
};

}  // namespace varbo::vhgp
