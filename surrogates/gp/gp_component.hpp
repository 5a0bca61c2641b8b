#pragma once
// The `gp` surrogate as a registry component: declared options, validation and factory.
#include "varbo/registry.hpp"

namespace varbo::gp {
ComponentInfo gp_component();
}  // namespace varbo::gp
