// The non-virtual parts of the Kernel interface: the parameter table, the default hyperprior and the defaults
// written in terms of the pure virtual methods.
#include "varbo/kernel.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cmath>
#include <stdexcept>

#include "varbo/errors.hpp"

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


namespace {
[[noreturn]] void wrong_shape(const Kernel& k, const char* method, const std::string& got, const std::string& expected) {
  throw PluginCodeError(fmt::format("a kernel's {} returned {} where {} was expected (kernel with hyperparameters [{}]; "
                                    "a mistake in the kernel's code)",
                                    method, got, expected, fmt::join(k.names(), ", ")));
}
void require(const Kernel& k, const char* method, const Mat& m, Index rows, Index cols) {
  if (m.rows() != rows || m.cols() != cols)
    wrong_shape(k, method, fmt::format("a {}×{} matrix", m.rows(), m.cols()), fmt::format("{}×{}", rows, cols));
}
void require(const Kernel& k, const char* method, const Vec& v, Index size) {
  if (v.size() != size) wrong_shape(k, method, fmt::format("{} values", v.size()), fmt::format("{}", size));
}
}  // namespace

Vec Kernel::cross_vec(const Vec& x, const Mat& X) const { return checked_cross(X, x.transpose()).col(0); }

Mat Kernel::checked_matrix(const Mat& X) const {
  Mat K = matrix(X);
  require(*this, "matrix()", K, X.rows(), X.rows());
  return K;
}
Mat Kernel::checked_cross(const Mat& X, const Mat& Z) const {
  Mat K = cross(X, Z);
  require(*this, "cross()", K, X.rows(), Z.rows());
  return K;
}
Vec Kernel::checked_cross_vec(const Vec& x, const Mat& X) const {
  Vec k = cross_vec(x, X);
  require(*this, "cross_vec()", k, X.rows());
  return k;
}
std::vector<Mat> Kernel::checked_matrix_gradients(const Mat& X) const {
  std::vector<Mat> G = matrix_gradients(X);
  if (static_cast<Index>(G.size()) != num_params())
    wrong_shape(*this, "matrix_gradients()", fmt::format("{} matrices", G.size()),
                fmt::format("{} (one per hyperparameter)", num_params()));
  for (const Mat& m : G) require(*this, "matrix_gradients()", m, X.rows(), X.rows());
  return G;
}
Mat Kernel::checked_cross_gradient_x(const Vec& x, const Mat& X) const {
  Mat G = cross_gradient_x(x, X);
  require(*this, "cross_gradient_x()", G, x.size(), X.rows());
  return G;
}
Vec Kernel::checked_contract_gradient(const Mat& X, const Mat& W) const {
  Vec g = contract_gradient(X, W);
  require(*this, "contract_gradient()", g, num_params());
  return g;
}

Vec Kernel::contract_gradient(const Mat& X, const Mat& W) const {
  const std::vector<Mat> G = checked_matrix_gradients(X);
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
