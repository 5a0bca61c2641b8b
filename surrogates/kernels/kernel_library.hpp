#pragma once
// The kernels of the `kernels` plugin as varbo::Kernel objects (framework/core/include/varbo/kernel.hpp).
// Surrogates normally get them from the registry (`kernel: {type: se_ard}`); these constructors serve the
// plugin's factories, tests, and a surrogate's fallback when it is built without a registry.
#include <memory>
#include <vector>

#include "kernel.hpp"
#include "varbo/kernel.hpp"

namespace varbo::kernels {

/// se_ard, matern12_ard, matern32_ard, matern52_ard: σ² ρ(r), r² = Σ_d (x_d − x'_d)²/ℓ_d².
/// Hyperparameters lengthscale[0..D-1], signal_std.
std::unique_ptr<Kernel> make_stationary_ard(KernelType type, Index dim);
/// rational_quadratic: σ² (1 + r²/(2α))^{−α} (R&W eq. 4.19). Hyperparameters lengthscale[0..D-1], signal_std, alpha.
std::unique_ptr<Kernel> make_rational_quadratic(Index dim);
/// linear: σ² x·x'. Hyperparameter signal_std.
std::unique_ptr<Kernel> make_linear(Index dim);
/// constant: σ². Hyperparameter signal_std.
std::unique_ptr<Kernel> make_constant(Index dim);
/// white: σ² δ_ij on K(X, X) and on k(x, x), 0 between different inputs (GPML's covNoise). Hyperparameter noise_std.
std::unique_ptr<Kernel> make_white(Index dim);
/// sum / product of terms (same dimension, at least one). Hyperparameters terms[i].<name of term i>.
std::unique_ptr<Kernel> make_sum(std::vector<std::unique_ptr<Kernel>> terms);
std::unique_ptr<Kernel> make_product(std::vector<std::unique_ptr<Kernel>> terms);

/// The defaults a kernel declares for each role (the `gp` defaults: lengthscale prior median 0.5 sd 1 in
/// [0.01, 50]; amplitudes median 1 sd 1 in [0.05, 20]; noise median 0.01 sd 3 in [1e-6, 2], standardized units).
KernelParameter lengthscale_parameter(Index i);
KernelParameter amplitude_parameter(std::string name = "signal_std");
KernelParameter noise_parameter();

}  // namespace varbo::kernels
