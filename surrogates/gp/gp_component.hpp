#pragma once
// The `gp` surrogate as a registry component: declared options, validation and factory.
#include "gp_surrogate.hpp"
#include "varbo/option_set.hpp"
#include "varbo/registry.hpp"

namespace varbo::gp {
ComponentInfo gp_component();
/// The options of `gp`; those with a GpSettings field are bound to it (the kernel and optimizer components,
/// output_transform and hyperparameters are read by the factory).
const OptionSet<GpSettings>& gp_options();
}  // namespace varbo::gp
