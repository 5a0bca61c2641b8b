#include "vhgp_objective.hpp"

#include <limits>

namespace varbo::vhgp {

std::unique_ptr<Kernel> VhgpHyperprior::configured(const Kernel& form, Process process) const {
  std::unique_ptr<Kernel> k = form.clone();
  const bool f = process == Process::F;
  k->set_role_defaults(KernelParameterRole::Lengthscale, f ? lengthscale_f : lengthscale_g, 1e-3, 1e3);
  k->set_role_defaults(KernelParameterRole::Amplitude, f ? signal_f : signal_g, f ? 1e-3 : 1e-4, f ? 1e2 : 30.0);
  return k;
}

VhgpObjective::VhgpObjective(const VhgpBound& bound, const VhgpHyperprior& prior)
    : bound_(bound),
      prior_(prior),
      f_(prior.configured(bound.f_form(), Process::F)),
      g_(prior.configured(bound.g_form(), Process::G)) {}

VhgpObjective::VhgpObjective(const VhgpBound& bound, const VhgpHyperprior& prior, const VhgpParams& fixed)
    : VhgpObjective(bound, prior) {
  lambda_only_ = true;
  fixed_ = fixed;
}

Index VhgpObjective::dim() const { return lambda_only_ ? bound_.size() : bound_.num_params(); }

VhgpParams VhgpObjective::params(const Vec& x) const {
  if (!lambda_only_) return bound_.unpack(x);
  VhgpParams p = fixed_;
  p.log_lambda = x;
  return p;
}

double VhgpObjective::log_prior(const VhgpParams& p, VhgpGradient* grad) const {
  if (!prior_.enabled) return 0.0;
  Vec gf, gg;
  double d = 0.0;
  double lp = f_->log_prior(p.theta_f, grad ? &gf : nullptr);
  lp += g_->log_prior(p.theta_g, grad ? &gg : nullptr);
  lp += prior_.mu0.log_density(p.mu0, &d);
  if (grad) {
    grad->theta_f += gf;
    grad->theta_g += gg;
    grad->mu0 += d;
  }
  return lp;
}

double VhgpObjective::value(const Vec& x, Vec* grad) const {
  const VhgpParams p = params(x);
  BoundValue b = bound_.evaluate(p, grad != nullptr);
  if (!b.ok) {
    if (grad) *grad = Vec::Zero(dim());
    return -std::numeric_limits<double>::infinity();
  }
  const double lp = log_prior(p, grad ? &b.gradient : nullptr);
  if (grad) *grad = lambda_only_ ? b.gradient.log_lambda : b.gradient.pack();
  return b.F + lp;
}

Box VhgpObjective::box() const {
  const Index n = bound_.size();
  VhgpParams lo, hi;
  lo.log_lambda = Vec::Constant(n, -15.0);
  hi.log_lambda = Vec::Constant(n, 12.0);
  const Box bf = f_->log_box(), bg = g_->log_box();
  lo.theta_f = bf.lower;
  hi.theta_f = bf.upper;
  lo.theta_g = bg.lower;
  hi.theta_g = bg.upper;
  lo.mu0 = kMu0Lower;
  hi.mu0 = kMu0Upper;
  return Box{lo.pack(), hi.pack()};
}

}  // namespace varbo::vhgp
