#pragma once
// Augmented expected improvement (Huang, Allen, Notz & Zeng 2006, J. Global Optim. 34, eq. 11–13), with the
// noise variance at the candidate taken from the model, so that it is the heteroscedastic variant
// (Picheny, Wagner & Ginsbourger 2013, section 3.2.2) for a VHGP and Huang's original for a GP:
//
//   AEI(x) = E[max(μ(x**) − f(x), 0)] · (1 − σ_ε(x)/sqrt(s²(x) + σ_ε²(x)))
//
// f(x) ~ N(μ(x), s²(x)) is the *latent* cost (no noise in the improvement: a noisy draw is not an
// improvement), x** the evaluated point minimizing μ + c·s (Huang's "effective best", c = 1), σ_ε²(x) =
// E[exp(g(x))] the expected noise variance at x. The second factor discounts candidates whose evaluation would
// mostly measure noise; it is what makes the acquisition prefer low-noise regions when the noise varies with x.
// Kuindersma's EI instead integrates the improvement of the noisy y = f + ε over g, whose larger spread in
// high-noise regions *raises* EI there.
#include <string>

#include "varbo/acquisition.hpp"

namespace varbo::acq {

class AugmentedExpectedImprovement final : public Acquisition {
 public:
  /// c: the incumbent minimizes μ + c·s over the data (s the latent std); noise_factor: multiply by Huang's
  /// noise factor (false: plain EI on the latent cost over the same incumbent).
  AugmentedExpectedImprovement(double c, bool noise_factor) : c_(c), noise_factor_(noise_factor) {}
  void prepare(const AcquisitionContext& context) override;
  double evaluate(const Vec& x, Vec* grad) const override;
  std::string state() const override;

 private:
  double c_;
  bool noise_factor_;
  const Surrogate* model_ = nullptr;
  double mu_best_ = 0;  ///< μ(x**)
  Index best_ = -1;
};

}  // namespace varbo::acq
