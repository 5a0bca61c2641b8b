#pragma once
// A probabilistic model of the cost over the unit cube.
#include <string>
#include <utility>
#include <vector>
#include "varbo/prediction.hpp"
#include "varbo/types.hpp"

namespace varbo {

/// A named hyperparameter in natural units (lengthscale, signal standard deviation, ...).
struct Hyperparameter {
  std::string name;
  double value = 0;
};
using Hyperparameters = std::vector<Hyperparameter>;

/// What a fit did, in the spirit of Ceres' Summary.
struct FitReport {
  bool ok = true;            ///< false: the fit failed and the previous model was kept
  bool optimized = false;    ///< hyperparameters were optimized (not only conditioned)
  double objective = 0;      ///< log marginal likelihood (or bound) + log hyperprior
  double log_likelihood = 0; ///< without the hyperprior term
  double log_prior = 0;
  int restarts = 0;
  int restarts_failed = 0;
  double seconds = 0;
  std::string message;
  std::string report() const;
};

/// Threads: fit(), condition() and the setters are called from one thread; the const methods (predict() above
/// all) are called from many threads at once while an acquisition is optimized, so they must not modify state.
class Surrogate {
 public:
  virtual ~Surrogate();
  /// Optimizes hyperparameters on `data` (restarts in parallel) and conditions on it. Never throws on
  /// numerical trouble: a failed fit keeps the last good model and says so in the report.
  virtual FitReport fit(const Dataset& data, Rng& rng) = 0;
  /// Conditions on `data` with the current hyperparameters; reports the objective there.
  virtual FitReport condition(const Dataset& data) = 0;
  /// Predictive distribution at x (unit cube), in cost units. Thread-safe.
  virtual Prediction predict(const Vec& x, bool with_gradient) const = 0;
  /// σ_f², the prior variance of the latent cost in cost units (CRBO's confidence scale).
  virtual double signal_variance() const = 0;
  virtual Hyperparameters hyperparameters() const = 0;
  /// Sets hyperparameters by name (as reported by hyperparameters()); unknown names throw ConfigError.
  virtual void set_hyperparameters(const Hyperparameters& values) = 0;
  /// Extra named state for inspection and snapshots (e.g. VHGP's log Λ). Empty by default.
  virtual std::vector<std::pair<std::string, Vec>> state() const { return {}; }
  virtual void set_state(const std::string& name, const Vec& value);
  virtual bool ready() const = 0;  ///< conditioned on data at least once
  /// The model acquisitions score (EI, PI, CB, ERI and their incumbent): the surrogate itself, or, for a surrogate
  /// that warps its costs (output_transform), the inner Gaussian model in warped units, where those formulas are
  /// exact; a monotone warping keeps the order of means and quantiles (docs/output_transform.md).
  virtual const Surrogate& acquisition_model() const { return *this; }
  /// True when the model tests its data for noise and an exact replicate (the same θ twice) makes that test
  /// decisive: a deterministic cost then shows no difference at all. `bo` repeats a design point for such a
  /// model unless its `replicate_design` says otherwise (a gp with a noise test; docs/defaults.md, "Session se15").
  virtual bool tests_noise_on_replicates() const { return false; }
};

/// Optional for a Surrogate (found by dynamic_cast, as ComponentState): the posterior mean alone, equal to
/// predict(x, false).mean bit for bit, without the variance's O(N²) solve. `bo`'s recommendation rule evaluates
/// the mean at every data point after every trial of a run: with predict() that was O(N³) per trial, 0.8 s at
/// N = 1,100 with the plain default (red team, session 28). Thread-safe like predict().
class MeanPrediction {
 public:
  virtual ~MeanPrediction();
  virtual double predict_mean(const Vec& x) const = 0;
};

/// The posterior mean at x: by MeanPrediction when the surrogate offers it, else by predict().
double posterior_mean(const Surrogate& model, const Vec& x);

}  // namespace varbo
