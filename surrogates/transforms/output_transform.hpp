#pragma once
// Output (cost) warping for GP surrogates: the Yeo–Johnson power transform with λ fitted by maximum likelihood of
// the transformed-normal model, as scikit-learn's PowerTransformer and HEBO (Cowen-Rivers et al. 2022) do.
// Badly scaled costs (spanning orders of magnitude) make a GP on the raw values extrapolate wildly; a GP on the
// warped values sees a nearly Gaussian spread. docs/output_transform.md has the design and measurements.
#include <string>
#include <vector>
#include "varbo/prediction.hpp"
#include "varbo/types.hpp"

namespace varbo::transforms {

enum class OutputTransformType { None, YeoJohnson };
/// Names as written in configs: "none", "yeo_johnson".
std::vector<std::string> output_transform_names();
/// Throws std::invalid_argument naming the accepted values.
OutputTransformType parse_output_transform(const std::string& name);

// ψ_λ, the Yeo–Johnson transform (Yeo & Johnson 2000, eq. 2.1), for every real u:
//   u ≥ 0: ((1+u)^λ − 1)/λ      (log1p(u) at λ = 0)
//   u < 0: −((1−u)^(2−λ) − 1)/(2−λ)   (−log1p(−u) at λ = 2)
// Monotone increasing for every λ; its derivative is ψ'(u) = (1+|u|)^(±(λ−1)).
double yeo_johnson(double u, double lambda);
double yeo_johnson_derivative(double u, double lambda);         ///< dψ/du
double yeo_johnson_second_derivative(double u, double lambda);  ///< d²ψ/du²
/// ψ_λ⁻¹(z). For λ ∈ [0, 2] ψ maps ℝ onto ℝ; for λ < 0 the positive branch only reaches −1/λ (for λ > 2 the
/// negative one only −1/(λ−2)): beyond it the inverse is continued linearly from the point where |u| = cap
/// (finite and monotone; such predictions lie far outside the data anyway).
double yeo_johnson_inverse(double z, double lambda, double cap = 1e6);

/// Profile log-likelihood of λ under z = ψ_λ(u) ~ N(m, s²) with m, s² at their ML values (scipy's
/// yeojohnson_llf): −n/2 · log var(ψ_λ(u)) + (λ − 1) Σ sign(u_i) log(1 + |u_i|).
double yeo_johnson_log_likelihood(const Vec& u, double lambda);
/// argmax of the profile log-likelihood over [lo, hi] by Brent's method (Boost.Math).
double fit_yeo_johnson_lambda(const Vec& u, double lo, double hi);

/// The cost warping z = ψ_λ((y − shift)/scale) with shift = min(y), scale = median(y) − min(y) and λ ∈ [0, 2]
/// fitted on the data. Centring on the best cost and scaling by its distance to the median make the warping
/// invariant to affine changes of the cost units (a raw Yeo–Johnson is not) and put every observed cost on the
/// positive branch, where ψ is a Box–Cox transform of 1 + u: at λ = 0, log(1 + u), which compresses a heavy upper
/// tail; predictions below the best cost use the negative branch, which compresses them too. λ ≥ 0 keeps ψ onto
/// ℝ (no stronger compression than a log; for λ < 0 the inverse explodes near −1/λ).
class OutputTransform {
 public:
  static constexpr double kLambdaMin = 0.0, kLambdaMax = 2.0;

  OutputTransform() = default;
  explicit OutputTransform(OutputTransformType type) : type_(type) {}

  /// Fits shift, scale and λ to the costs y (identity when there are fewer than 3 distinct costs).
  void fit(const Vec& y);
  /// Sets the parameters directly (tests, inspection).
  void set(double shift, double scale, double lambda);

  OutputTransformType type() const { return type_; }
  double shift() const { return shift_; }
  double scale() const { return scale_; }
  double lambda() const { return lambda_; }

  double forward(double y) const;               ///< z(y)
  Vec forward(const Vec& y) const;
  double log_derivative(double y) const;        ///< log dz/dy (the Jacobian term of the likelihood)
  double inverse(double z) const;               ///< y(z)
  double inverse_derivative(double z) const;    ///< dy/dz > 0
  double inverse_second_derivative(double z) const;

  /// Maps a Gaussian predictive in warped units to cost units: mean = y(μ) is the *median* of the
  /// back-transformed predictive (exact, since y(·) is monotone), variances by the delta method
  /// (latent_var·y'(μ)², noise variance·y'(μ)²), gradients by the chain rule.
  Prediction to_cost(const Prediction& warped) const;

 private:
  OutputTransformType type_ = OutputTransformType::None;
  double shift_ = 0, scale_ = 1, lambda_ = 1;
  double cap_ = 1e6;  ///< |u| beyond which the inverse continues linearly (see yeo_johnson_inverse)
};

}  // namespace varbo::transforms
