#include "vhgp_objective.hpp"

#include <limits>

namespace varbo::vhgp {

double VhgpHyperprior::log_density(const VhgpParams& p, VhgpGradient* grad) const {
  if (!enabled) return 0.0;
  const Index dim = p.theta_f.size() - 1;
  double lp = 0.0, d = 0.0;
  for (Index i = 0; i <= dim; ++i) {
    const LogNormalPrior& pf = i < dim ? lengthscale_f : signal_f;
    const LogNormalPrior& pg = i < dim ? lengthscale_g : signal_g;
    lp += pf.log_density(p.theta_f(i), &d);
    if (grad) grad->theta_f(i) += d;
    lp += pg.log_density(p.theta_g(i), &d);
    if (grad) grad->theta_g(i) += d;
  }
  lp += mu0.log_density(p.mu0, &d);
  if (grad) grad->mu0 += d;
  return lp;
}

VhgpObjective::VhgpObjective(const VhgpBound& bound, const VhgpHyperprior& prior) : bound_(bound), prior_(prior) {}

VhgpObjective::VhgpObjective(const VhgpBound& bound, const VhgpHyperprior& prior, const VhgpParams& fixed)
    : bound_(bound), prior_(prior), lambda_only_(true), fixed_(fixed) {}

Index VhgpObjective::dim() const { return lambda_only_ ? bound_.size() : bound_.num_params(); }

VhgpParams VhgpObjective::params(const Vec& x) const {
  if (!lambda_only_) return VhgpParams::unpack(x, bound_.size(), bound_.dim());
  VhgpParams p = fixed_;
  p.log_lambda = x;
  return p;
}

double VhgpObjective::value(const Vec& x, Vec* grad) const {
  const VhgpParams p = params(x);
  BoundValue b = bound_.evaluate(p, grad != nullptr);
  if (!b.ok) {
    if (grad) *grad = Vec::Zero(dim());
    return -std::numeric_limits<double>::infinity();
  }
  const double lp = prior_.log_density(p, grad ? &b.gradient : nullptr);
  if (grad) *grad = lambda_only_ ? b.gradient.log_lambda : b.gradient.pack();
  return b.F + lp;
}

Box parameter_box(Index n, Index dim) {
  VhgpParams lo, hi;
  lo.log_lambda = Vec::Constant(n, -15.0);
  hi.log_lambda = Vec::Constant(n, 12.0);
  lo.theta_f = Vec::Constant(dim + 1, std::log(1e-3));  // lengthscales in the unit cube
  hi.theta_f = Vec::Constant(dim + 1, std::log(1e3));
  lo.theta_f(dim) = std::log(1e-3);                     // σ_f of standardized costs
  hi.theta_f(dim) = std::log(1e2);
  lo.theta_g = lo.theta_f;
  hi.theta_g = hi.theta_f;
  lo.theta_g(dim) = std::log(1e-4);                     // σ_g: std of the log noise variance
  hi.theta_g(dim) = std::log(30.0);
  lo.mu0 = -30.0;
  hi.mu0 = 8.0;
  return Box{lo.pack(), hi.pack()};
}

}  // namespace varbo::vhgp
