#pragma once
// EI, PI, CB and ERI on the shared Prediction, valid for GP and VHGP alike (Kuindersma 2013, section 3).
// Costs are minimized, so every acquisition returns a utility to maximize (−CB for the confidence bound).
#include <string>

#include "noise_quadrature.hpp"
#include "varbo/acquisition.hpp"
#include "varbo/math.hpp"

namespace varbo::acq {

/// Which incumbent an improvement-type acquisition needs: μ_best (and s_best) from the model at the data.
struct Target {
  double mu_best = 0;
  double s_best = 0;
  Index index = -1;
};

/// EI and PI: E_g*[F(δ, v)] with the margin δ = μ_best − ξσ_f − a* (eq. 9 for F = EI's integrand), by
/// Gauss–Hermite over g* or in closed form; the two differ only in F. ξ is scaled by σ_f = sqrt(signal_variance())
/// so that it is in cost units whatever the cost scale; ξ ≥ 0 asks for an improvement of at least ξ·σ_f.
class ImprovementAcquisition : public Acquisition {
 public:
  void prepare(const AcquisitionContext& context) final;
  double evaluate(const Vec& x, Vec* grad) const final;
  std::string state() const final;

 protected:
  ImprovementAcquisition(const char* name, Integrand integrand, double xi, int gh_nodes)
      : name_(name), integrand_(integrand), xi_(xi), rule_(gauss_hermite(gh_nodes)) {}

 private:
  const char* name_;
  Integrand integrand_;
  double xi_;
  const GaussHermite& rule_;  ///< cached: gauss_hermite() takes a lock
  const Surrogate* model_ = nullptr;
  Target target_;
  double margin_ = 0;  ///< μ_best − ξσ_f
};

/// Expected improvement over μ_best − ξσ_f (Kuindersma 2013, eq. 9).
class ExpectedImprovement final : public ImprovementAcquisition {
 public:
  ExpectedImprovement(double xi, int gh_nodes) : ImprovementAcquisition("ei", improvement_integrand, xi, gh_nodes) {}
};

/// Probability of improvement P(y* < μ_best − ξσ_f) = Φ(u), integrated over g* for a heteroscedastic model
/// (Kushner's convention for ξ: with Kuindersma's EI sign, μ_best + ξ, PI would be 1 at the incumbent for any
/// ξ > 0 and never explore).
class ProbabilityOfImprovement final : public ImprovementAcquisition {
 public:
  ProbabilityOfImprovement(double xi, int gh_nodes)
      : ImprovementAcquisition("pi", probability_integrand, xi, gh_nodes) {}
};

/// Confidence bound CB = E[y*] + κ·s*, s* = sqrt(V[y*]) (eq. 10 with b = κ s*); the utility is −CB.
/// κ > 0 is risk-averse, κ < 0 risk-seeking. With `randomize`, κ ~ N(0, 1) is drawn in prepare()
/// (the paper's randomized CB selection, section 5).
class ConfidenceBound final : public Acquisition {
 public:
  ConfidenceBound(double kappa, bool randomize) : kappa_(kappa), randomize_(randomize) {}
  void prepare(const AcquisitionContext& context) override;
  double evaluate(const Vec& x, Vec* grad) const override;
  std::string state() const override;
  double kappa() const { return kappa_; }

 private:
  double kappa_;
  bool randomize_;
  const Surrogate* model_ = nullptr;
};

/// Expected risk improvement (eq. 12): the EI integrand with u = (μ_best − a* + κ(s_best − s*) − ξσ_f)/v (ξ > 0
/// asks for more improvement, as in EI),
/// where (μ_best, s_best) is the evaluated point minimizing E + κ·s. ERI(κ = 0) = EI.
class ExpectedRiskImprovement final : public Acquisition {
 public:
  ExpectedRiskImprovement(double kappa, double xi, int gh_nodes) : kappa_(kappa), xi_(xi), rule_(gauss_hermite(gh_nodes)) {}
  void prepare(const AcquisitionContext& context) override;
  double evaluate(const Vec& x, Vec* grad) const override;
  std::string state() const override;

 private:
  double kappa_;
  double xi_;
  const GaussHermite& rule_;  ///< cached: gauss_hermite() takes a lock
  const Surrogate* model_ = nullptr;
  Target target_;
  double margin_ = 0;  ///< μ_best + κ s_best − ξσ_f
};

/// The incumbent under the model (Kuindersma 2013, Alg. 2): lowest E + κ·s over the evaluated points.
Target find_target(const AcquisitionContext& context, double kappa);
/// σ_f = sqrt(signal_variance()), 0 when the model reports nonsense.
double signal_std(const Surrogate& model);

}  // namespace varbo::acq
