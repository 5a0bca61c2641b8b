#pragma once
// Variable risk after learning (Kuindersma 2013, section 3.2, eq. 10 and 20): for each risk factor κ, the θ
// minimizing CB(θ, κ) = E[y] + κ·s under an already fitted model, chosen without evaluating the task.
// κ > 0 is risk-averse (prefers low cost variance), κ < 0 risk-seeking, κ = 0 risk-neutral.
#include <string>
#include <vector>

#include "varbo/search_space.hpp"
#include "varbo/optimizer.hpp"
#include "varbo/surrogate.hpp"
#include "varbo/task.hpp"

namespace varbo {

/// The policy chosen for one κ.
struct RiskSelection {
  double kappa = 0;
  Vec x;            ///< unit cube
  Vec theta;        ///< user units (the task's domain)
  double mean = 0;  ///< E[y] at θ, cost units
  double std = 0;   ///< s = sqrt(V[y]) at θ: latent and noise variance (Kuindersma 2013, section 2.2)
  double criterion = 0;  ///< E[y] + κ·s, the minimized value
  /// sd of the latent cost at θ relative to σ_f: near 1 the model knows nothing there (far from the data), so
  /// E and s are the prior's and the selection is an extrapolation.
  double relative_latent_std = 0;
  bool ok = false;
  std::string message;
};

/// sd of the latent cost at a prediction relative to σ_f (RiskSelection::relative_latent_std).
double relative_latent_std(const Surrogate& model, const Prediction& p);
/// A selection whose latent sd is more than this share of σ_f lies where the model knows little: its E and s
/// are extrapolations (issue 10 saw predicted means far below the true minimum there). `varbo select`, `varbo
/// rescore` and the dashboard flag it.
inline constexpr double kExtrapolating = 0.5;

/// The utility −(E[y] + κ·s) to maximize (eq. 20), with its analytic gradient (unit-cube coordinates); the one
/// implementation behind `varbo select` and `varbo rescore` (RiskObjective). A model that gives no gradient
/// where one is asked for is a NumericalError (a zero gradient would stop a gradient search at its start).
class NegativeConfidenceBound : public DifferentiableFunction {
 public:
  NegativeConfidenceBound(const Surrogate& model, Index dim, double kappa);
  Index dim() const override { return dim_; }
  double value(const Vec& x, Vec* grad) const override;
  /// False for a surrogate without gradients (a third party's may have none): then searched by values; its empty
  /// gradient was an error the local search swallowed, so no point was ever polished (red team, session 30).
  bool has_gradient() const override { return gradients_; }

 private:
  const Surrogate& model_;
  Index dim_;
  double kappa_;
  bool gradients_ = true;
};

/// For each κ, maximizes −(E + κ·s) over the unit cube with `optimizer`, started from the rows of `starts`
/// (e.g. the evaluated points; may be empty) and the optimizer's own candidates. `model` must be ready.
/// Each κ draws from its own stream of `rng` (derived from κ's value), so one κ's answer does not depend on
/// the others in the list. The result is in the order of `kappas`; θ is mapped to `domain.box`.
/// With a search space (typed parameters, docs/search_space.md) the cube is its encoding, the search keeps to its
/// constraints and θ is the admissible point decoded.
/// With `failed` points (unit cube rows: trials that failed, e.g. a robot that fell), a selection must lie at least
/// twice as far from every failed point as from its nearest point of `starts` (the successful trials): a region
/// around the successes that keeps away from the failures beside them. Without it the model, which knows nothing
/// of failures, chose the extrapolated corner beyond them (red team, session 24). The optimizer must then handle
/// a constraint.
std::vector<RiskSelection> select_policies(const Surrogate& model, const Domain& domain,
                                           const std::vector<double>& kappas, const Optimizer& optimizer,
                                           const Rng& rng, const Mat& starts = Mat(), const SharedSpace& space = nullptr,
                                           const Mat& failed = Mat());

/// For each κ, the row of `points` (unit cube, e.g. the evaluated θ) minimizing E + κ·s: the selection that
/// never leaves the data (Kuindersma 2013, Alg. 2 picks among evaluated policies the same way).
std::vector<RiskSelection> select_among(const Surrogate& model, const Domain& domain,
                                        const std::vector<double>& kappas, const Mat& points,
                                        const SharedSpace& space = nullptr);

}  // namespace varbo
