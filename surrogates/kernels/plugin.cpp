#include "kernel_components.hpp"
#include "varbo/plugin.hpp"

VARBO_PLUGIN("kernels", "0.1.0", "Covariance functions: SE, Matern 1/2, 3/2, 5/2 and rational quadratic ARD, "
                                 "linear, constant, white, sum and product") {
  for (auto& c : varbo::kernels::kernel_components()) registry.add(std::move(c));
}
