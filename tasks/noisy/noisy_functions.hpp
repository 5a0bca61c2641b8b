#pragma once
// The test functions of the noisy suite, BBOB-style (Hansen, Finck, Ros & Auger, "Real-Parameter Black-Box
// Optimization Benchmarking 2009: Noiseless Functions Definitions", INRIA RR-6829): each function is evaluated
// at z = transform(x - x_opt) on [-5, 5]^d, where an `instance` fixes x_opt and the rotations; f* is known.
// Simplifications, stated once: f_opt = 0 (so f - f* = f), no oscillation/asymmetry transforms (T_osz, T_asy)
// and no boundary penalty f_pen (the domain is the box). Branin and Hartmann-6 keep their usual domains and
// reuse tasks/benchmarks; their instances reflect (and for Hartmann-6 permute) the coordinates.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "varbo/types.hpp"

namespace varbo::tasks::noisy {

/// One function at one (dimension, instance): the noise-free cost, its domain and its known minimum.
struct FunctionInstance {
  std::function<double(const Vec&)> f;  ///< user units, x in `box`
  Box box;
  double fstar = 0;            ///< min over the box
  std::vector<Vec> argmins;    ///< every global minimizer (user units)
};

struct NoisyFunctionSpec {
  std::string name;
  std::string description;  ///< formula and f*, for --describe
  Index fixed_dim = 0;      ///< > 0: defined only for this dimension
  Index min_dim = 1;
  /// Builds the function for dimension d and instance k >= 1 (deterministic in (name, d, k)).
  std::function<FunctionInstance(Index d, long instance)> make;
};

/// The ten functions, in a fixed order: sphere, rosenbrock, ellipsoid, step_ellipsoid, rastrigin, schaffer,
/// griewank_rosenbrock, gallagher, branin, hartmann6.
const std::vector<NoisyFunctionSpec>& noisy_function_specs();
const NoisyFunctionSpec& noisy_function_spec(const std::string& name);  // throws std::out_of_range
std::vector<std::string> noisy_function_names();

/// A uniformly random rotation (Haar measure: QR of a Gaussian matrix with the signs of R's diagonal fixed).
Mat random_rotation(Index d, Rng& rng);

}  // namespace varbo::tasks::noisy
