#pragma once
// The `gp` surrogate as a registry component: declared options, validation and factory.
#include "varbo/registry.hpp"

namespace varbo::gp {
ComponentInfo gp_component();
/// Reads `hyperparameters: {lengthscale: 0.3 | [..], lengthscale[0]: .., signal_std: .., noise_std: .., mean: ..}`.
/// A key K that is not itself in `names` but whose K[0], K[1], ... are stands for all of them: a number sets
/// each, a list gives one value each. Unknown names are left to Surrogate::set_hyperparameters.
Hyperparameters parse_hyperparameters(const ConfigNode& node, const std::vector<std::string>& names);
}  // namespace varbo::gp
