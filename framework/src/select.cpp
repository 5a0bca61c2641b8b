// Risk-sensitive policy selection on a fitted model (Kuindersma 2013, section 3.2, eq. 20).
#include "varbo/select.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <limits>
#include <cmath>
#include <stdexcept>

#include "varbo/errors.hpp"
#include "varbo/math.hpp"

namespace varbo {

double NegativeConfidenceBound::value(const Vec& x, Vec* grad) const {
  const Prediction p = model_.predict(x, grad != nullptr);
  // s = sqrt(c*² + exp(μ* + σ*²/2)) (section 2.2); ds/dx = dV/dx / (2 s).
  const double s = p.total_std();
  if (grad != nullptr) {
    if (!p.has_gradient()) throw NumericalError("select: the model gave no gradient");
    const Vec d_std = p.d_total_var() / (2.0 * std::max(s, 1e-300));
    *grad = -(p.d_mean + kappa_ * d_std);
  }
  return -(p.mean + kappa_ * s);
}

std::vector<RiskSelection> select_policies(const Surrogate& model, const Domain& domain,
                                           const std::vector<double>& kappas, const Optimizer& optimizer,
                                           const Rng& rng, const Mat& starts) {
  if (!model.ready()) throw InputError("select: the model is not fitted (no data?)");
  const Index d = domain.box.dim();
  if (d < 1) throw InputError("select: the domain has no parameters");
  if (starts.size() > 0 && starts.cols() != d)
    throw InputError(fmt::format("select: starting points have {} columns, the domain {}", starts.cols(), d));
  const BoxRegion unit(Box::unit(d));
  std::vector<RiskSelection> out;
  out.reserve(kappas.size());
  for (double kappa : kappas) {
    RiskSelection r;
    r.kappa = kappa;
    if (!std::isfinite(kappa)) {
      r.message = "kappa is not finite";
      out.push_back(r);
      continue;
    }
    const NegativeConfidenceBound f(model, d, kappa);
    // The stream depends only on κ's value: selecting [2, -2] or [-2] gives the same answer for -2.
    Rng krng = rng.stream(0x5e1ec7, std::bit_cast<std::uint64_t>(kappa == 0.0 ? 0.0 : kappa));
    OptimizeResult res;
    try {
      res = optimizer.maximize(f, unit, starts, krng);
    } catch (const std::exception& e) {
      res.success = false;
      res.message = e.what();
    }
    if (res.x.size() != d || !res.x.allFinite()) {
      r.message = fmt::format("the optimizer found no point ({})", res.message);
      out.push_back(r);
      continue;
    }
    r.x = Box::unit(d).clamp(res.x);
    const Prediction p = model.predict(r.x, false);
    r.mean = p.mean;
    r.std = p.total_std();
    r.criterion = r.mean + kappa * r.std;
    r.relative_latent_std = std::sqrt(std::max(0.0, p.latent_var) / std::max(model.signal_variance(), 1e-300));
    r.theta = from_unit(r.x, domain.box);
    r.ok = std::isfinite(r.criterion);
    r.message = r.ok ? res.message : "non-finite prediction at the optimizer's point";
    out.push_back(std::move(r));
  }
  return out;
}

}  // namespace varbo

namespace varbo {

std::vector<RiskSelection> select_among(const Surrogate& model, const Domain& domain,
                                        const std::vector<double>& kappas, const Mat& points) {
  if (!model.ready()) throw InputError("select: the model is not fitted (no data?)");
  const Index d = domain.box.dim();
  if (points.rows() == 0 || points.cols() != d)
    throw InputError(fmt::format("select: {} candidate points of dimension {}, the domain has {}", points.rows(),
                                 points.cols(), d));
  std::vector<Prediction> p;
  for (Index i = 0; i < points.rows(); ++i) p.push_back(model.predict(points.row(i).transpose(), false));
  std::vector<RiskSelection> out;
  for (double kappa : kappas) {
    RiskSelection r;
    r.kappa = kappa;
    if (!std::isfinite(kappa)) {
      r.message = "kappa is not finite";
      out.push_back(r);
      continue;
    }
    double best = std::numeric_limits<double>::infinity();
    for (Index i = 0; i < points.rows(); ++i) {
      const Prediction& q = p[static_cast<std::size_t>(i)];
      const double v = q.mean + kappa * q.total_std();
      if (!(v < best)) continue;
      best = v;
      r.x = points.row(i).transpose();
      r.mean = q.mean;
      r.std = q.total_std();
      r.criterion = v;
      r.relative_latent_std = std::sqrt(std::max(0.0, q.latent_var) / std::max(model.signal_variance(), 1e-300));
    }
    r.ok = std::isfinite(best);
    if (r.ok) r.theta = from_unit(r.x, domain.box);
    else r.message = "no candidate has a finite E + kappa*s";
    out.push_back(r);
  }
  return out;
}

}  // namespace varbo
