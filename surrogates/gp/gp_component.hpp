#pragma once
// The `gp` surrogate as a registry component: declared options, validation and factory.
#include <string>

#include "gp_surrogate.hpp"
#include "varbo/option_set.hpp"
#include "varbo/registry.hpp"

namespace varbo::gp {
ComponentInfo gp_component();
/// The options of `gp`; those with a GpSettings field are bound to it (the kernel and optimizer components,
/// output_transform and hyperparameters are read by the factory).
const OptionSet<GpSettings>& gp_options();
/// The fit optimizer `gp` declares by default (also the one of the vhgp's gp member, homoscedastic_member: gp).
inline constexpr const char* kDefaultFitOptimizer = "{type: ceres_lbfgs, max_iterations: 100}";
/// The noise floor `gp` uses with `kernel` when min_noise_std is not given: kSeArdMinNoiseStd for se_ard, else
/// `configured` (capped by max_noise_std).
double default_min_noise_std(const std::string& kernel, double configured, double max_noise_std);
}  // namespace varbo::gp
