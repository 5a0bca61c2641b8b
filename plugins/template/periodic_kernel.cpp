// Template for a third-party kernel, "periodic": k(x, x') = σ² exp(−2 Σ_d sin²(π (x_d − x'_d)/p) / ℓ²)
// (MacKay 1998; R&W eq. 4.31, one period and one lengthscale for every dimension).
// Copy this file, rename the plugin and the component, and build it against an installed varbo (CMakeLists.txt).
// A kernel declares its hyperparameters once (name, role, log-normal prior, box) and implements K, K(X, Z), the
// derivative matrices ∂K/∂log θ_j and the input gradient; everything else has a default (varbo/kernel.hpp).
// Use it from a config as `kernel: periodic` or inside `{type: sum, terms: [periodic, se_ard]}`.
#include <cmath>
#include <varbo/plugin.hpp>

namespace {

using varbo::Index;
using varbo::Mat;
using varbo::Vec;

class Periodic final : public varbo::Kernel {
 public:
  Periodic(Index dim, double period_median) : dim_(dim) {
    // Lengthscale and signal_std take the surrogate's priors and bounds (their roles); the period is ours.
    declare({{"lengthscale", varbo::KernelParameterRole::Lengthscale, {std::log(0.5), 1.0}, 0.01, 50.0, false},
             {"period", varbo::KernelParameterRole::Shape, {std::log(period_median), 0.5}, 0.05, 5.0, false},
             {"signal_std", varbo::KernelParameterRole::Amplitude, {0.0, 1.0}, 0.05, 20.0, true}});
  }
  std::unique_ptr<varbo::Kernel> clone() const override { return std::make_unique<Periodic>(*this); }
  Index dim() const override { return dim_; }

  Mat matrix(const Mat& X) const override { return cross(X, X); }
  Mat cross(const Mat& X, const Mat& Z) const override {
    Mat K(X.rows(), Z.rows());
    for (Index j = 0; j < Z.rows(); ++j)
      for (Index i = 0; i < X.rows(); ++i) K(i, j) = value(X.row(i).transpose() - Z.row(j).transpose());
    return K;
  }
  double diagonal(const Vec&) const override { return s2(); }

  // ∂k/∂log ℓ = k·4S/ℓ²,  ∂k/∂log p = k·(2π/(ℓ²p)) Σ_d δ_d sin(2πδ_d/p),  ∂k/∂log σ = 2k,  S = Σ_d sin²(πδ_d/p).
  std::vector<Mat> matrix_gradients(const Mat& X) const override {
    const Index n = X.rows();
    std::vector<Mat> G(3, Mat(n, n));
    const double l2 = ell() * ell(), p = period();
    for (Index j = 0; j < n; ++j)
      for (Index i = 0; i < n; ++i) {
        const Vec delta = X.row(i).transpose() - X.row(j).transpose();
        const double k = value(delta);
        double S = 0.0, T = 0.0;
        for (Index d = 0; d < dim_; ++d) {
          S += std::pow(std::sin(M_PI * delta(d) / p), 2);
          T += delta(d) * std::sin(2.0 * M_PI * delta(d) / p);
        }
        G[0](i, j) = k * 4.0 * S / l2;
        G[1](i, j) = k * 2.0 * M_PI * T / (l2 * p);
        G[2](i, j) = 2.0 * k;
      }
    return G;
  }
  // ∂k(x, X_i)/∂x_d = −k·(2π/(ℓ²p)) sin(2π(x_d − X_id)/p)
  Mat cross_gradient_x(const Vec& x, const Mat& X) const override {
    Mat G(dim_, X.rows());
    const double l2 = ell() * ell(), p = period();
    for (Index i = 0; i < X.rows(); ++i) {
      const Vec delta = x - X.row(i).transpose();
      const double k = value(delta);
      for (Index d = 0; d < dim_; ++d) G(d, i) = -k * 2.0 * M_PI * std::sin(2.0 * M_PI * delta(d) / p) / (l2 * p);
    }
    return G;
  }

 private:
  double ell() const { return std::exp(log_params()(0)); }
  double period() const { return std::exp(log_params()(1)); }
  double s2() const { return std::exp(2.0 * log_params()(2)); }
  double value(const Vec& delta) const {
    double S = 0.0;
    for (Index d = 0; d < dim_; ++d) S += std::pow(std::sin(M_PI * delta(d) / period()), 2);
    return s2() * std::exp(-2.0 * S / (ell() * ell()));
  }
  Index dim_;
};

}  // namespace

VARBO_PLUGIN("template_kernel", "1.0.0", "Example third-party kernel") {
  registry.add(varbo::make_component<varbo::Kernel>(
      "periodic", "exp-sine-squared kernel with one period and one lengthscale (template plugin)",
      {varbo::opt::real("period_median", 1.0, "median of the period prior (unit cube)").above(0)},
      varbo::Factory<varbo::Kernel>([](const varbo::Options& o, const varbo::BuildContext& ctx) {
        if (ctx.dim < 1) throw std::invalid_argument("periodic: the problem dimension is not known");
        return std::make_unique<Periodic>(ctx.dim, o.real("period_median"));
      }),
      {"kernel"}));
}
