#include <cmath>

#include "kernel_library.hpp"

namespace varbo::kernels {

KernelParameter lengthscale_parameter(Index i) {
  return {"lengthscale[" + std::to_string(i) + "]", KernelParameterRole::Lengthscale, {std::log(0.5), 1.0}, 0.01,
          50.0, false};
}

KernelParameter amplitude_parameter(std::string name) {
  return {std::move(name), KernelParameterRole::Amplitude, {0.0, 1.0}, 0.05, 20.0, true};
}

KernelParameter noise_parameter() {
  return {"noise_std", KernelParameterRole::Noise, {std::log(1e-2), 3.0}, 1e-6, 2.0, true};
}

}  // namespace varbo::kernels
