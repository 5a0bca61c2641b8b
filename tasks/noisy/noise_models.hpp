#pragma once
// Observation-noise models of the noisy suite. Each acts on g = f(x) - f* >= 0 and returns the noisy g̃; the
// observed cost is f* + g̃. Levels follow the BBOB noisy testbed (Hansen, Auger, Finck & Ros, "Real-Parameter
// Black-Box Optimization Benchmarking 2009: Noisy Functions Definitions", INRIA RR-6869, sec. 2) where it has one:
//
//   none                    g̃ = g
//   additive                g̃ = g + σ N,                       σ = 0.1 (moderate) | 1 (severe)
//   multiplicative          g̃ = g exp(β N),                    β = 0.01 | 1                    (BBOB f_GN)
//   uniform_multiplicative  g̃ = g U1^β max(1, (1e9/(g + 1e-99))^{α U2}),
//                           α = 0.01(0.49 + 1/d), β = 0.01 | α = 0.49 + 1/d, β = 1            (BBOB f_UN)
//   cauchy                  g̃ = g + α max(-1000, 1{U < p} N1/(|N2| + 1e-199)),
//                           α = 0.01, p = 0.05 | α = 1, p = 0.2                             (BBOB f_CN less
//                           its constant offset 1000α, which shifts every value alike)
//   input_dependent         g̃ = g + σ(u) N, σ(u) = σ (0.02 + 1.98 ū), ū = mean of x's unit-cube coordinates,
//                           σ = 0.1 | 1: from 0.02σ at the lower corner to 2σ at the upper one, ≈ σ on average
//
// N, N1, N2 ~ N(0, 1) and U, U1, U2 ~ U[0, 1) are independent draws from the trial's stream, only. Every g̃
// is clipped to [-1e12, 1e12] so a cost is always finite (never reached in practice: a Cauchy draw beyond
// 1e12/α has probability ~6e-13). BBOB's extra +1.01e-8 after noise is left out.
#include <string>
#include <vector>

#include "varbo/types.hpp"

namespace varbo::tasks::noisy {

enum class NoiseModel { None, Additive, Multiplicative, UniformMultiplicative, Cauchy, InputDependent };
enum class NoiseLevel { Moderate, Severe };

std::vector<std::string> noise_model_names();  ///< in enum order
NoiseModel noise_model_from_name(const std::string& name);  // throws std::invalid_argument
std::string noise_model_name(NoiseModel m);
NoiseLevel noise_level_from_name(const std::string& name);  // throws std::invalid_argument
std::string noise_level_name(NoiseLevel l);

/// True for the models whose variance depends on x (multiplicative, uniform multiplicative, input-dependent) or
/// that are not Gaussian-homoscedastic (Cauchy outliers): the "heteroscedastic" group of bench/noisy.
bool heteroscedastic(NoiseModel m);

/// A model at a level, with its constants resolved for dimension d.
struct Noise {
  NoiseModel model = NoiseModel::None;
  NoiseLevel level = NoiseLevel::Moderate;
  double sigma = 0;  ///< additive, input_dependent
  double beta = 0;   ///< multiplicative, uniform_multiplicative
  double alpha = 0;  ///< uniform_multiplicative, cauchy
  double p = 0;      ///< cauchy: fraction of evaluations hit by an outlier

  static Noise make(NoiseModel model, NoiseLevel level, Index d);
  /// σ(u) of input_dependent at unit-cube coordinates u.
  double input_sigma(const Vec& u) const;
  /// g̃ for g = f - f* (negative g from rounding is treated as 0 by the multiplicative models); `u` is x in the
  /// unit cube (used by input_dependent only). Draws from `rng` only when the model is not None.
  double apply(double g, const Vec& u, Rng& rng) const;
  /// One line with the formula and constants, for logs and table headers.
  std::string describe() const;
};

inline constexpr double kNoiseClip = 1e12;

}  // namespace varbo::tasks::noisy
