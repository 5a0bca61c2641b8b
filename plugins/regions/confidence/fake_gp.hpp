#pragma once
// Test support: a minimal exact GP with a squared-exponential kernel and fixed hyperparameters, with
// closed-form latent variance and gradients (Rasmussen & Williams 2006, eqs. 2.25–2.26). It lets the tests of
// the confidence region, the hit-and-run sampler and sample_polish run without the real `gp` plugin.
#include <cmath>

#include "varbo/math.hpp"
#include "varbo/surrogate.hpp"

namespace varbo::test {

class FakeSEGP final : public Surrogate {
 public:
  FakeSEGP(double signal_var, double lengthscale, double noise_var)
      : sf2_(signal_var), ell_(lengthscale), sn2_(noise_var) {}

  FitReport fit(const Dataset& data, Rng&) override { return condition(data); }
  FitReport condition(const Dataset& data) override {
    X_ = data.X;
    const Index n = data.size();
    Mat K(n, n);
    for (Index i = 0; i < n; ++i)
      for (Index j = 0; j < n; ++j) K(i, j) = k(X_.row(i).transpose(), X_.row(j).transpose());
    K.diagonal().array() += sn2_;
    llt_.compute(K);
    alpha_ = llt_.solve(data.y);
    ready_ = true;
    return {};
  }
  double k(const Vec& a, const Vec& b) const { return sf2_ * std::exp(-0.5 * (a - b).squaredNorm() / (ell_ * ell_)); }

  Prediction predict(const Vec& x, bool with_gradient) const override {
    Prediction p;
    p.log_noise_mean = std::log(sn2_);
    const Index n = X_.rows();
    Vec ks(n);
    for (Index i = 0; i < n; ++i) ks[i] = k(x, X_.row(i).transpose());
    const Vec v = n > 0 ? Vec(llt_.solve(ks)) : Vec(0);
    p.mean = n > 0 ? ks.dot(alpha_) : 0.0;
    p.latent_var = std::max(0.0, sf2_ - ks.dot(v));
    if (with_gradient) {
      p.d_mean = Vec::Zero(x.size());
      p.d_latent_var = Vec::Zero(x.size());
      for (Index i = 0; i < n; ++i) {
        const Vec dk = -ks[i] * (x - X_.row(i).transpose()) / (ell_ * ell_);  // ∂k(x, x_i)/∂x
        p.d_mean += alpha_[i] * dk;
        p.d_latent_var += -2.0 * v[i] * dk;  // ∂(σ_f² − kᵀK⁻¹k)/∂x
      }
      p.d_log_noise_mean = Vec::Zero(x.size());
      p.d_log_noise_var = Vec::Zero(x.size());
    }
    return p;
  }
  double signal_variance() const override { return sf2_; }
  Hyperparameters hyperparameters() const override {
    return {{"lengthscale", ell_}, {"signal_variance", sf2_}, {"noise_variance", sn2_}};
  }
  void set_hyperparameters(const Hyperparameters&) override {}
  bool ready() const override { return ready_; }

 private:
  double sf2_, ell_, sn2_;
  Mat X_;
  Vec alpha_;
  Eigen::LLT<Mat> llt_;
  bool ready_ = false;
};

}  // namespace varbo::test
