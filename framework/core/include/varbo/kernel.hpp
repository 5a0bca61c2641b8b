#pragma once
// A covariance function k(x, x') over the unit cube, the component kind `kernel` (docs/plugins.md, "Writing a
// kernel"). Surrogates (gp, vhgp) take one as their `kernel:` option; `sum` and `product` compose them.
//
// Hyperparameters live in log space, one value per positive quantity (log ℓ, log σ, log α, ...). Each has a
// stable name (`lengthscale[0]`, `signal_std`, composites prefix `terms[i].`), a role that lets the surrogate
// apply its own prior and bounds to every lengthscale or amplitude, a log-normal hyperprior and a fit box.
// The kernel holds its current values (log_params / set_log_params); the matrix methods use them.
//
// Threads: every const method may be called from many threads at once. A surrogate that evaluates the kernel at
// several parameter vectors concurrently clones it (clone()) and sets the values on each copy.
#include <memory>
#include <string>
#include <vector>

#include "varbo/math.hpp"
#include "varbo/types.hpp"

namespace varbo {

/// What a hyperparameter is, so a surrogate can set one prior and one range for all of a kind at once.
enum class KernelParameterRole {
  Lengthscale,  ///< a length on the unit cube
  Amplitude,    ///< a standard deviation of the modelled function (k scales with its square)
  Noise,        ///< a standard deviation of independent noise (white kernel)
  Shape,        ///< anything else (rational-quadratic α, ...)
};

struct KernelParameter {
  std::string name;          ///< stable, used by `hyperparameters:` maps and fit JSON
  KernelParameterRole role = KernelParameterRole::Shape;
  LogNormalPrior prior;      ///< on the log value (Kuindersma 2013, eq. 13)
  double lower = 1e-3;       ///< fit box, natural units (lengthscales on the unit cube, std relative to std(y))
  double upper = 1e3;
  /// Natural value ∝ the scale of the costs (a standard deviation of the modelled function or of noise): a
  /// surrogate that standardizes its costs multiplies it by std(y). In a product only the first term's amplitude
  /// carries the scale (the others are dimensionless factors), so the map stays one-to-one.
  bool scales_with_output = false;
};

class Kernel {
 public:
  virtual ~Kernel();
  virtual std::unique_ptr<Kernel> clone() const = 0;

  /// Input dimension D (rows of X are points in R^D).
  virtual Index dim() const = 0;
  /// Name, role, prior and box of each hyperparameter, in the order of log_params().
  const std::vector<KernelParameter>& parameters() const { return parameters_; }
  Index num_params() const { return static_cast<Index>(parameters_.size()); }
  std::vector<std::string> names() const;
  const Vec& log_params() const { return log_params_; }
  /// Sets the log values (throws std::invalid_argument for a wrong size) and calls params_changed().
  void set_log_params(const Vec& log_params);

  /// K(X, X) (N × N, symmetric).
  virtual Mat matrix(const Mat& X) const = 0;
  /// K(X, Z) (N × M). For kernels with an index-based term (white noise) cross(X, X) ≠ matrix(X).
  virtual Mat cross(const Mat& X, const Mat& Z) const = 0;
  /// k(x, X_i) for every row i. Default: one column of cross().
  virtual Vec cross_vec(const Vec& x, const Mat& X) const;
  /// k(x, x), the prior variance at one point (white noise included).
  virtual double diagonal(const Vec& x) const = 0;

  /// g_j = ½ Σ_ik W_ik ∂K_ik/∂θ_j for symmetric W, θ = log params: what marginal-likelihood gradients need
  /// (R&W eq. 5.9), without forming every derivative matrix. Default: through matrix_gradients().
  virtual Vec contract_gradient(const Mat& X, const Mat& W) const;
  /// ∂K(X, X)/∂θ_j for every j (tests, and models that need the matrices).
  virtual std::vector<Mat> matrix_gradients(const Mat& X) const = 0;
  /// Column i = ∂k(x, X_i)/∂x (D × N). At a point where k is not differentiable (Matérn-1/2 at x = X_i) a
  /// subgradient (zero).
  virtual Mat cross_gradient_x(const Vec& x, const Mat& X) const = 0;

  /// log p(θ) and, when grad is given, ∂/∂θ, at log values θ (the kernel's own values are not used). Default:
  /// the sum of the parameters' independent log-normal priors, in the order of parameters().
  virtual double log_prior(const Vec& log_params, Vec* grad) const;
  /// The fit box in log space: [log lower_j, log upper_j].
  Box log_box() const;

  /// The virtual results above with their shapes checked; what surrogates call. A third-party kernel whose
  /// matrix_gradients() returned one matrix for two hyperparameters crashed varbo and the Python interpreter, and
  /// one a row short made a seeded run differ from itself (red team, session 31). A wrong shape or count throws
  /// PluginCodeError naming the method, the sizes and the kernel's hyperparameters.
  Mat checked_matrix(const Mat& X) const;
  Mat checked_cross(const Mat& X, const Mat& Z) const;
  Vec checked_cross_vec(const Vec& x, const Mat& X) const;
  std::vector<Mat> checked_matrix_gradients(const Mat& X) const;
  Mat checked_cross_gradient_x(const Vec& x, const Mat& X) const;
  Vec checked_contract_gradient(const Mat& X, const Mat& W) const;

  /// Replaces the prior and the box of every hyperparameter with this role (how `gp`'s lengthscale_prior_*,
  /// min_lengthscale, ... options reach any kernel, composites included).
  virtual void set_role_defaults(KernelParameterRole role, const LogNormalPrior& prior, double lower, double upper);

 protected:
  /// Subclasses declare their hyperparameters once, in the constructor; values start at the priors' medians.
  void declare(std::vector<KernelParameter> parameters);
  /// Called after set_log_params (composites pass slices to their terms; others may cache derived values).
  virtual void params_changed() {}

 private:
  std::vector<KernelParameter> parameters_;
  Vec log_params_;
};

}  // namespace varbo
