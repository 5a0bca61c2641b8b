#pragma once
// The confidence region of cautious BO (Fröhlich et al. 2021, eq. 3):
//   C_n = {θ in the unit box : σ_n(θ) ≤ γ·σ_f},
// written as the smooth constraint c(θ) = s·γ²σ_f² − c*²(θ) ≥ 0 on the LATENT predictive variance c*²
// (Prediction::latent_var, never the observation noise), so that a heteroscedastic surrogate's noise model
// does not shrink the region. s ≥ 1 is the widening scale (see update()).
#include <string>

#include "cautiousness.hpp"
#include "varbo/region.hpp"

namespace varbo {

struct ConfidenceRegionOptions {
  double gamma = 0.6;          ///< γ in (0, 1): the region's size parameter (paper: 0.3–0.9 per task)
  double probe_radius = 0.01;  ///< distance (unit cube) of the probe points around the data
  int probes_per_point = 4;    ///< random probes per data point for the emptiness test
  int max_widenings = 50;      ///< crbo.md: at most 50 widenings
  double widening_factor = 1.2;///< crbo.md: the variance scale is multiplied by 1.2 each time
  bool report = true;          ///< compute the cautiousness report (section 4.1) in update()
  ReportKernel report_kernel = ReportKernel::Matern52;  ///< kernel assumed by the report's r0
};

class ConfidenceRegion final : public RegionConstraint {
 public:
  ConfidenceRegion(Index dim, ConfidenceRegionOptions options);

  /// Stores the model pointer (the caller keeps the model alive until the next update) and the data.
  /// If no probe point near the data lies strictly inside C_n, the variance scale s is multiplied by
  /// `widening_factor` until one does (at most `max_widenings` times), and that is logged.
  void update(const Surrogate* model, const Dataset& data, Rng& rng) override;
  const Box& bounds() const override { return box_; }
  bool has_constraint() const override { return true; }
  /// s·γ²σ_f² − latent_var(x); gradient −d latent_var. Before the first update: 1 (the whole box).
  double constraint(const Vec& x, Vec* grad) const override;
  /// The data points inside C_n (all data points if none is, which only happens after failed widening).
  Mat seeds() const override;
  std::string state() const override;

  double gamma() const { return options_.gamma; }
  double variance_scale() const { return scale_; }
  int widenings() const { return widenings_; }
  const Surrogate* model() const { return model_; }
  const Dataset& data() const { return data_; }
  /// γ_eff = γ·sqrt(s): the γ actually in force after widening.
  double effective_gamma() const;
  /// Extra line appended to state() (e.g. the cautiousness report); set by the owner after update.
  void set_report(std::string report) { report_ = std::move(report); }

 private:
  bool probes_feasible(Rng& rng) const;

  ConfidenceRegionOptions options_;
  Box box_;
  const Surrogate* model_ = nullptr;
  Dataset data_;
  double signal_var_ = 1.0;
  double scale_ = 1.0;
  int widenings_ = 0;
  bool said_empty_ = false;  ///< the "still empty" warning, once per region
  std::string report_;
};

}  // namespace varbo
