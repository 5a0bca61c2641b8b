#pragma once
// The `gp` surrogate as a registry component: declared options, validation and factory.
#include <string>

#include "gp_surrogate.hpp"
#include "varbo/option_set.hpp"
#include "varbo/registry.hpp"

namespace varbo::gp {
ComponentInfo gp_component();
/// `auto`: the gp's default `kernel`, a name in the registry's kernels so that it validates, shows in
/// `varbo plugins` and is written to config.resolved.yaml like any kernel; it builds no kernel itself (a gp with
/// it chooses among kAutoCandidates at each full fit; any other user of a kernel gets a ConfigError).
ComponentInfo auto_kernel_component();
inline constexpr const char* kAutoKernel = "auto";
/// What `kernel: auto` chooses among when kernel_candidates is not given: Matérn-5/2 first (with
/// kernel_choice_margin 3 it is kept unless SE-ARD fits clearly better; docs/defaults.md, "Kernel chosen by the
/// data").
inline constexpr const char* kAutoCandidates = "[matern52_ard, se_ard]";
/// The options of `gp`; those with a GpSettings field are bound to it (the kernel and optimizer components,
/// output_transform and hyperparameters are read by the factory).
const OptionSet<GpSettings>& gp_options();
/// The fit optimizer `gp` declares by default (also the one of the vhgp's gp member, homoscedastic_member: gp).
inline constexpr const char* kDefaultFitOptimizer = "{type: ceres_lbfgs, max_iterations: 100}";
/// The noise floor `gp` uses with `kernel` when min_noise_std is not given: kSeArdMinNoiseStd for se_ard, else
/// `configured` (capped by max_noise_std).
double default_min_noise_std(const std::string& kernel, double configured, double max_noise_std);
}  // namespace varbo::gp
