#pragma once
// A surrogate that models warped costs: z = T(y) with T an OutputTransform refitted on every fit/condition,
// wrapped around an inner surrogate (gp, vhgp) that sees only z.
//
// What each consumer sees:
//  - predict(): cost units. mean = T⁻¹(μ_z), the median of the back-transformed predictive (exact for a monotone
//    T); variances by the delta method, (dT⁻¹/dz)²·var_z at μ_z. The negative branch compresses predictions
//    below the best cost.
//  - acquisition_model(): the inner model in warped units, so EI/PI/CB/ERI are computed exactly for the Gaussian
//    model they assume (as HEBO does). Incumbents and κ-quantiles there map back monotonically: the point with
//    the lowest μ_z + κ s_z is the point with the lowest T⁻¹(μ_z + κ s_z), a quantile of the cost predictive.
//  - hyperparameters()/set_hyperparameters(): the inner model's, in warped units (signal_std, noise_std, mean of z).
//  - signal_variance(): in cost units, σ_f,z² · (sd(y)/sd(z))².
#include <memory>
#include <string>
#include "output_transform.hpp"
#include "varbo/surrogate.hpp"

namespace varbo::transforms {

class TransformedSurrogate final : public Surrogate {
 public:
  TransformedSurrogate(std::unique_ptr<Surrogate> inner, OutputTransformType type);

  FitReport fit(const Dataset& data, Rng& rng) override;
  FitReport condition(const Dataset& data) override;
  Prediction predict(const Vec& x, bool with_gradient) const override;
  double signal_variance() const override;
  Hyperparameters hyperparameters() const override { return inner_->hyperparameters(); }
  void set_hyperparameters(const Hyperparameters& values) override { inner_->set_hyperparameters(values); }
  /// The inner state plus "output_transform" = [shift, scale, λ] (read-only: refitted with the data).
  std::vector<std::pair<std::string, Vec>> state() const override;
  void set_state(const std::string& name, const Vec& value) override;
  bool ready() const override { return inner_->ready(); }
  const Surrogate& acquisition_model() const override { return inner_->acquisition_model(); }
  /// A monotone warping keeps an exact replicate exact, so the inner model's noise test still applies.
  bool tests_noise_on_replicates() const override { return inner_->tests_noise_on_replicates(); }

  const OutputTransform& transform() const { return transform_; }
  const Surrogate& inner() const { return *inner_; }

 private:
  /// Refits the transform on data.y and returns the warped data set.
  Dataset warp(const Dataset& data);
  /// Adds the log-Jacobian Σ log dz/dy so likelihoods are densities of the costs.
  FitReport in_cost_units(FitReport report, const Dataset& data) const;

  std::unique_ptr<Surrogate> inner_;
  OutputTransform transform_;
  double cost_sd_ = 1, warped_sd_ = 1;  ///< sd of the costs and of the warped costs at the last fit
};

/// Wraps `inner` when `type` is not None; returns it unchanged otherwise.
std::unique_ptr<Surrogate> with_output_transform(std::unique_ptr<Surrogate> inner, OutputTransformType type);

/// The `output_transform` option text shared by gp and vhgp (their option declarations use it).
inline const char* output_transform_description() {
  return "warp the costs before modelling: none, or yeo_johnson (Yeo-Johnson power transform of "
         "(y - min y)/(median y - min y), lambda in [0, 2] fitted by maximum likelihood, then standardized; for costs "
         "spanning orders of magnitude). Predictions stay in cost units (mean = median of the back-transformed "
         "predictive, delta-method variance); acquisitions work in the warped units; hyperparameters are those of "
         "the warped model";
}

}  // namespace varbo::transforms
