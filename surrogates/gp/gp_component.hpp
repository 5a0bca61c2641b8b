#pragma once
// The `gp` surrogate as a registry component: declared options, validation and factory.
#include "varbo/registry.hpp"

namespace varbo::gp {
ComponentInfo gp_component();
/// Reads `hyperparameters: {lengthscale: 0.3 | [..], lengthscale[0]: .., signal_std: .., noise_std: .., mean: ..}`.
Hyperparameters parse_hyperparameters(const ConfigNode& node, Index dim);
}  // namespace varbo::gp
