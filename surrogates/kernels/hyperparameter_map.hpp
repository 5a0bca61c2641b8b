#pragma once
// The one reader of `hyperparameters:` maps, shared by gp and vhgp (issue 12, item 3):
//   hyperparameters: {lengthscale: 0.3, signal_std: 1.5, "lengthscale[1]": 0.2, terms[0].lengthscale: [0.2, 0.5]}
// Keys are the names a surrogate's hyperparameters() reports. A key K that is not itself a name but whose K[0],
// K[1], ... are stands for all of them: a number sets each, a list gives one value each (exactly as many).
// Values must be finite numbers, and positive unless their name is in `signed_names` (a mean, VHGP's μ0).
// Names the surrogate does not know are passed through: Surrogate::set_hyperparameters refuses them with the
// list of known names. Errors: ConfigError at the offending key or value (file:line:col).
#include <string>
#include <vector>

#include "varbo/config.hpp"
#include "varbo/surrogate.hpp"

namespace varbo::kernels {

Hyperparameters parse_hyperparameter_map(const ConfigNode& node, const std::vector<std::string>& names,
                                         const std::vector<std::string>& signed_names);

}  // namespace varbo::kernels
