// sum and product: kernels built from kernels. Hyperparameters are the terms' in order, named terms[i].<name>.
#include <stdexcept>

#include "kernel_library.hpp"

namespace varbo::kernels {

namespace {

class Composite : public Kernel {
 public:
  explicit Composite(std::vector<std::unique_ptr<Kernel>> terms) : terms_(std::move(terms)) {
    if (terms_.empty()) throw std::invalid_argument("a composite kernel needs at least one term");
    for (const auto& t : terms_)
      if (t->dim() != terms_[0]->dim()) throw std::invalid_argument("the terms of a composite kernel differ in dimension");
  }
  Composite(const Composite& other) : Kernel(other) {
    for (const auto& t : other.terms_) terms_.push_back(t->clone());
  }
  Index dim() const override { return terms_[0]->dim(); }

  /// Each term's own prior on its slice (a term may override log_prior).
  double log_prior(const Vec& log_params, Vec* grad) const override {
    if (grad) grad->setZero(num_params());
    double total = 0.0;
    Index offset = 0;
    for (const auto& t : terms_) {
      Vec g;
      total += t->log_prior(log_params.segment(offset, t->num_params()), grad ? &g : nullptr);
      if (grad) grad->segment(offset, t->num_params()) = g;
      offset += t->num_params();
    }
    return total;
  }
  void set_role_defaults(KernelParameterRole role, const LogNormalPrior& prior, double lower, double upper) override {
    Kernel::set_role_defaults(role, prior, lower, upper);
    for (auto& t : terms_) t->set_role_defaults(role, prior, lower, upper);
  }

 protected:
  /// The terms' parameter tables, prefixed. In a product only the first term that scales with the costs keeps
  /// scales_with_output (k scales by s² once, not once per factor).
  void declare_from_terms(bool only_first_scales) {
    std::vector<KernelParameter> all;
    bool scaled = false;
    for (std::size_t i = 0; i < terms_.size(); ++i) {
      bool term_scales = false;
      for (KernelParameter p : terms_[i]->parameters()) {
        p.name = "terms[" + std::to_string(i) + "]." + p.name;
        if (only_first_scales && p.scales_with_output) {  // an amplitude or a white term's noise_std
          if (scaled) p.scales_with_output = false;
          term_scales = true;
        }
        all.push_back(std::move(p));
      }
      scaled = scaled || term_scales;
    }
    declare(std::move(all));
  }
  void params_changed() override {
    Index offset = 0;
    for (auto& t : terms_) {
      t->set_log_params(log_params().segment(offset, t->num_params()));
      offset += t->num_params();
    }
  }
  std::vector<std::unique_ptr<Kernel>> terms_;
};

class Sum final : public Composite {
 public:
  explicit Sum(std::vector<std::unique_ptr<Kernel>> terms) : Composite(std::move(terms)) { declare_from_terms(false); }
  std::unique_ptr<Kernel> clone() const override { return std::make_unique<Sum>(*this); }
  Mat matrix(const Mat& X) const override { return add([&](const Kernel& t) { return t.checked_matrix(X); }); }
  Mat cross(const Mat& X, const Mat& Z) const override { return add([&](const Kernel& t) { return t.checked_cross(X, Z); }); }
  Vec cross_vec(const Vec& x, const Mat& X) const override {
    return add([&](const Kernel& t) -> Mat { return t.checked_cross_vec(x, X); });
  }
  double diagonal(const Vec& x) const override {
    double s = 0.0;
    for (const auto& t : terms_) s += t->diagonal(x);
    return s;
  }
  Vec contract_gradient(const Mat& X, const Mat& W) const override {
    Vec g(num_params());
    Index offset = 0;
    for (const auto& t : terms_) {
      g.segment(offset, t->num_params()) = t->checked_contract_gradient(X, W);
      offset += t->num_params();
    }
    return g;
  }
  std::vector<Mat> matrix_gradients(const Mat& X) const override {
    std::vector<Mat> G;
    for (const auto& t : terms_)
      for (Mat& m : t->checked_matrix_gradients(X)) G.push_back(std::move(m));
    return G;
  }
  Mat cross_gradient_x(const Vec& x, const Mat& X) const override {
    return add([&](const Kernel& t) { return t.checked_cross_gradient_x(x, X); });
  }

 private:
  template <class F>
  Mat add(F f) const {
    Mat total = f(*terms_[0]);
    for (std::size_t i = 1; i < terms_.size(); ++i) total += f(*terms_[i]);
    return total;
  }
};

/// K = K_1 ∘ K_2 ∘ ...: ∂K/∂θ (of term j) = ∂K_j/∂θ ∘ Π_{o≠j} K_o, so term j contracts W ∘ Π_{o≠j} K_o.
class Product final : public Composite {
 public:
  explicit Product(std::vector<std::unique_ptr<Kernel>> terms) : Composite(std::move(terms)) {
    declare_from_terms(true);
  }
  std::unique_ptr<Kernel> clone() const override { return std::make_unique<Product>(*this); }
  Mat matrix(const Mat& X) const override { return multiply([&](const Kernel& t) { return t.checked_matrix(X); }); }
  Mat cross(const Mat& X, const Mat& Z) const override {
    return multiply([&](const Kernel& t) { return t.checked_cross(X, Z); });
  }
  Vec cross_vec(const Vec& x, const Mat& X) const override {
    return multiply([&](const Kernel& t) -> Mat { return t.checked_cross_vec(x, X); });
  }
  double diagonal(const Vec& x) const override {
    double p = 1.0;
    for (const auto& t : terms_) p *= t->diagonal(x);
    return p;
  }
  Vec contract_gradient(const Mat& X, const Mat& W) const override {
    const std::vector<Mat> K = each([&](const Kernel& t) { return t.checked_matrix(X); });
    Vec g(num_params());
    Index offset = 0;
    for (std::size_t j = 0; j < terms_.size(); ++j) {
      g.segment(offset, terms_[j]->num_params()) = terms_[j]->checked_contract_gradient(X, W.cwiseProduct(others(K, j)));
      offset += terms_[j]->num_params();
    }
    return g;
  }
  std::vector<Mat> matrix_gradients(const Mat& X) const override {
    const std::vector<Mat> K = each([&](const Kernel& t) { return t.checked_matrix(X); });
    std::vector<Mat> G;
    for (std::size_t j = 0; j < terms_.size(); ++j) {
      const Mat rest = others(K, j);
      for (Mat& m : terms_[j]->checked_matrix_gradients(X)) G.push_back(m.cwiseProduct(rest));
    }
    return G;
  }
  Mat cross_gradient_x(const Vec& x, const Mat& X) const override {
    // Column i: Σ_j ∂k_j(x, X_i)/∂x Π_{o≠j} k_o(x, X_i).
    const std::vector<Mat> k = each([&](const Kernel& t) -> Mat { return t.checked_cross_vec(x, X).transpose(); });
    Mat G = Mat::Zero(dim(), X.rows());
    for (std::size_t j = 0; j < terms_.size(); ++j)
      G += terms_[j]->checked_cross_gradient_x(x, X) * others(k, j).row(0).asDiagonal();
    return G;
  }

 private:
  template <class F>
  std::vector<Mat> each(F f) const {
    std::vector<Mat> out;
    for (const auto& t : terms_) out.push_back(f(*t));
    return out;
  }
  template <class F>
  Mat multiply(F f) const {
    Mat total = f(*terms_[0]);
    for (std::size_t i = 1; i < terms_.size(); ++i) total = total.cwiseProduct(f(*terms_[i]));
    return total;
  }
  /// Π_{o≠j} M_o (ones when there is no other term).
  static Mat others(const std::vector<Mat>& M, std::size_t j) {
    Mat p = Mat::Ones(M[j].rows(), M[j].cols());
    for (std::size_t o = 0; o < M.size(); ++o)
      if (o != j) p = p.cwiseProduct(M[o]);
    return p;
  }
};

}  // namespace

std::unique_ptr<Kernel> make_sum(std::vector<std::unique_ptr<Kernel>> terms) {
  return std::make_unique<Sum>(std::move(terms));
}
std::unique_ptr<Kernel> make_product(std::vector<std::unique_ptr<Kernel>> terms) {
  return std::make_unique<Product>(std::move(terms));
}

}  // namespace varbo::kernels
