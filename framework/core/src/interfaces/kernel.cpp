// The non-virtual parts of the Kernel interface: the parameter table, the default hyperprior and the defaults
// written in terms of the pure virtual methods.
#include "varbo/kernel.hpp"

#include <cmath>
#include <stdexcept>

namespace varbo {

Kernel::~Kernel() = default;

std::vector<std::string> Kernel::names() const {
  std::vector<std::string> out;
  out.reserve(parameters_.size());
  for (const auto& p : parameters_) out.push_back(p.name);
  return out;
}

void Kernel::declare(std::vector<KernelParameter> parameters) {
  parameters_ = std::move(parameters);
  log_params_.resize(num_params());
  for (Index j = 0; j < num_params(); ++j) log_params_(j) = parameters_[static_cast<std::size_t>(j)].prior.mean;
  params_changed();
}

void Kernel::set_log_params(const Vec& log_params) {
  if (log_params.size() != num_params())
    throw std::invalid_argument("Kernel::set_log_params: expected " + std::to_string(num_params()) +
                                " values, got " + std::to_string(log_params.size()));
  log_params_ = log_params;
  params_changed();
}

Vec Kernel::cross_vec(const Vec& x, const Mat& X) const { return cross(X, x.transpose()).col(0); }

Vec Kernel::contract_gradient(const Mat& X, const Mat& W) const {
  const std::vector<Mat> G = matrix_gradients(X);
  Vec g(num_params());
  for (Index j = 0; j < num_params(); ++j) g(j) = 0.5 * (W.array() * G[static_cast<std::size_t>(j)].array()).sum();
  return g;
}

double Kernel::log_prior(const Vec& log_params, Vec* grad) const {
  if (grad) grad->setZero(num_params());
  // Kuindersma 2013, eq. (13): Σ_j log N(log ψ_j | μ_j, s_j²).
  double total = 0.0;
  for (Index j = 0; j < num_params(); ++j) {
    double dj = 0.0;
    total += parameters_[static_cast<std::size_t>(j)].prior.log_density(log_params(j), grad ? &dj : nullptr);
    if (grad) (*grad)(j) = dj;
  }
  return total;
}

Box Kernel::log_box() const {
  Box b{Vec(num_params()), Vec(num_params())};
  for (Index j = 0; j < num_params(); ++j) {
    b.lower(j) = std::log(parameters_[static_cast<std::size_t>(j)].lower);
    b.upper(j) = std::log(parameters_[static_cast<std::size_t>(j)].upper);
  }
  return b;
}

void Kernel::set_role_defaults(KernelParameterRole role, const LogNormalPrior& prior, double lower, double upper) {
  for (auto& p : parameters_)
    if (p.role == role) {
      p.prior = prior;
      p.lower = lower;
      p.upper = upper;
    }
}

}  // namespace varbo
