#include "gp_component.hpp"
#include "varbo/plugin.hpp"

VARBO_PLUGIN("gp", "0.1.0", "Homoscedastic Gaussian-process surrogate (SE-ARD / Matern-5/2 ARD)") {
  registry.add(varbo::gp::gp_component());
  registry.add(varbo::gp::auto_kernel_component());
}
