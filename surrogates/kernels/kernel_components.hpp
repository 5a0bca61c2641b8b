#pragma once
// The registry entries of the `kernels` plugin (component kind `kernel`).
#include <vector>

#include "varbo/registry.hpp"

namespace varbo::kernels {

std::vector<ComponentInfo> kernel_components();

}  // namespace varbo::kernels
