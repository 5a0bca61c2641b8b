#pragma once
// The `vhgp` surrogate: a variational heteroscedastic GP of the cost (Kuindersma 2013, section 2.2; eq. 6–7,
// 13). Costs are standardized inside (y_s = (y − m)/s); every reported quantity is in cost units.
#include <memory>
#include <optional>
#include "varbo/optimizer.hpp"
#include "varbo/surrogate.hpp"
#include "vhgp_objective.hpp"

namespace varbo::vhgp {

struct VhgpConfig {
  VhgpKernels kernels;
  int restarts = 8;
  bool standardize = true;
  bool warm_start = true;
  bool lambda_warmup = false;  ///< optimize log Λ alone first (the authors' first phase; ~2× the time, rarely better)
  int restart_evaluations = 40;  ///< stage-1 evaluations per start; 0: every start runs to convergence
  int finalists = 2;             ///< starts optimized to convergence after stage 1 (2 keeps both cores busy)
  bool fixed_hyperparameters = false;  ///< fit() optimizes log Λ only, at the given (or default) hyperparameters
  /// A full fit (homoscedastic init + all restarts) when N has grown by this factor since the last one; in
  /// between only the warm start is optimized. ≤ 1: every fit is full.
  double full_fit_growth = 1.0;
  VhgpHyperprior prior;
};

class VhgpSurrogate final : public Surrogate {
 public:
  VhgpSurrogate(Index dim, VhgpConfig config, std::shared_ptr<const Optimizer> fit_optimizer);

  FitReport fit(const Dataset& data, Rng& rng) override;
  FitReport condition(const Dataset& data) override;
  Prediction predict(const Vec& x, bool with_gradient) const override;
  double signal_variance() const override;
  Hyperparameters hyperparameters() const override;
  void set_hyperparameters(const Hyperparameters& values) override;
  std::vector<std::pair<std::string, Vec>> state() const override;
  void set_state(const std::string& name, const Vec& value) override;
  bool ready() const override { return posterior_ != nullptr; }

  /// The bound F in cost units at the current parameters (valid after fit/condition).
  double bound() const { return bound_; }
  /// The predictive of the latent quantities in model (standardized) units, for tests.
  LatentPrediction predict_latent(const Vec& x, bool with_gradient) const;
  const VhgpConfig& config() const { return config_; }

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

  Index dim_;
  VhgpConfig config_;
  std::shared_ptr<const Optimizer> optimizer_;
  std::optional<CostParams> params_;  ///< given or fitted hyperparameters (cost units)
  Vec bound_gradient_;  ///< ∂F at the parameters of the last condition() (model units), for inspection
  Scaling scaling_;
  std::shared_ptr<const VhgpPosterior> posterior_;
  double bound_ = 0;
  Index last_full_fit_n_ = 0;  ///< N at the last full fit (0: none yet)
};

}  // namespace varbo::vhgp
