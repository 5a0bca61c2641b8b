#include "vhgp_kernels.hpp"

#include <stdexcept>
#include <utility>

#include "kernel_library.hpp"

namespace varbo::vhgp {

KernelSpec::KernelSpec(KernelType type)
    : make_([type](Index dim) { return kernels::make_stationary_ard(type, dim); }) {}

KernelSpec::KernelSpec(KernelMaker make) : make_(std::move(make)) {
  if (!make_) throw std::invalid_argument("vhgp: KernelSpec without a kernel maker");
}

std::unique_ptr<Kernel> KernelSpec::build(Index dim) const {
  std::unique_ptr<Kernel> k = make_(dim);
  if (!k || k->dim() != dim) throw std::invalid_argument("vhgp: the kernel was not built for dimension " + std::to_string(dim));
  return k;
}

JitteredKernel::JitteredKernel(const Kernel& form, const Vec& theta, double jitter) : jitter_(jitter) {
  std::unique_ptr<Kernel> k = form.clone();
  k->set_log_params(theta);
  k_ = std::move(k);
}

Mat JitteredKernel::training_matrix(const Mat& X) const {
  Mat K = k_->checked_matrix(X);
  if (jitter_ != 0.0) K.diagonal() *= 1.0 + jitter_;
  return K;
}

Vec JitteredKernel::contract_gradient(const Mat& X, const Mat& W) const {
  if (jitter_ == 0.0) return k_->checked_contract_gradient(X, W);
  // Σ_ik W_ik ∂(jitter·δ_ik K_ii) = Σ_i (jitter·W_ii) ∂K_ii: the same contraction with W_ii·(1 + jitter).
  Mat Wj = W;
  Wj.diagonal() *= 1.0 + jitter_;
  return k_->checked_contract_gradient(X, Wj);
}

Vec JitteredKernel::prior_variance_gradient(const Vec& x) const {
  const Mat at = x.transpose();
  return 2.0 * (1.0 + jitter_) * k_->checked_cross_gradient_x(x, at).col(0);
}

std::string process_name(const std::string& kernel_name, Process p) {
  const std::string suffix = p == Process::F ? "_f" : "_g";
  // The last identifier starts after the last '.', and ends at its index bracket if it has one.
  const std::size_t start = kernel_name.rfind('.') == std::string::npos ? 0 : kernel_name.rfind('.') + 1;
  const std::size_t bracket = kernel_name.find('[', start);
  if (bracket == std::string::npos) return kernel_name + suffix;
  return kernel_name.substr(0, bracket) + suffix + kernel_name.substr(bracket);
}

Index dimension_of(const std::string& kernel_name) {
  static const std::string key = "lengthscale[";
  const std::size_t at = kernel_name.rfind(key);
  if (at == std::string::npos || kernel_name.back() != ']') return -1;
  const std::string digits = kernel_name.substr(at + key.size(), kernel_name.size() - at - key.size() - 1);
  if (digits.empty() || digits.find_first_not_of("0123456789") != std::string::npos) return -1;
  return static_cast<Index>(std::stol(digits));
}

Vec values_by_role(const Kernel& form, double log_lengthscale, double log_amplitude, double log_noise) {
  Vec v(form.num_params());
  for (Index j = 0; j < v.size(); ++j) {
    const KernelParameter& p = form.parameters()[static_cast<std::size_t>(j)];
    switch (p.role) {
      case KernelParameterRole::Lengthscale: v(j) = log_lengthscale; break;
      case KernelParameterRole::Amplitude: v(j) = p.scales_with_output ? log_amplitude : 0.0; break;
      case KernelParameterRole::Noise: v(j) = log_noise; break;
      case KernelParameterRole::Shape: v(j) = p.prior.mean; break;
    }
  }
  return v;
}

Vec output_scaling(const Kernel& form) {
  Vec m(form.num_params());
  for (Index j = 0; j < m.size(); ++j) m(j) = form.parameters()[static_cast<std::size_t>(j)].scales_with_output ? 1.0 : 0.0;
  return m;
}

}  // namespace varbo::vhgp
