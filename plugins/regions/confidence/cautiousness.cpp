#include "cautiousness.hpp"

#include <fmt/format.h>

#include <boost/math/tools/roots.hpp>
#include <algorithm>
#include <cmath>
#include <limits>

namespace varbo {

namespace {
double correlation(ReportKernel kernel, double r, double ell) {
  if (kernel == ReportKernel::SquaredExponential) return std::exp(-0.5 * r * r / (ell * ell));
  const double a = std::sqrt(5.0) * r / ell;
  return (1 + a + a * a / 3) * std::exp(-a);
}
}  // namespace

double single_point_radius(ReportKernel kernel, double ell, double gamma) {
  if (!(gamma < 1)) return std::numeric_limits<double>::infinity();
  if (!(gamma > 0) || !(ell > 0)) return 0.0;
  if (kernel == ReportKernel::SquaredExponential) return ell * std::sqrt(-std::log1p(-gamma * gamma));
  // ρ(r) is decreasing from 1 to 0: bracket the root of ρ(r) − sqrt(1 − γ²) on [0, hi] and solve.
  const double target = std::sqrt(1 - gamma * gamma);
  auto g = [&](double r) { return correlation(kernel, r, ell) - target; };
  double hi = ell;
  while (g(hi) > 0 && hi < 1e6 * ell) hi *= 2;
  std::uintmax_t iters = 200;
  const auto [a, b] = boost::math::tools::toms748_solve(g, 0.0, hi, g(0.0), g(hi),
                                                        boost::math::tools::eps_tolerance<double>(50), iters);
  return 0.5 * (a + b);
}

double paper_radius(double ell, double gamma) {
  if (!(gamma < 1)) return std::numeric_limits<double>::infinity();
  return std::sqrt(-2 * ell * ell * std::log1p(-gamma * gamma));
}

std::string CautiousnessReport::text() const {
  return fmt::format("cautiousness: r0 {:.4g} (l_max {:.4g}; paper eq. 4: {:.4g}), L {:.4g}, r0*L {:.4g}, "
                     "incumbent mean {:.6g}, worst-case next cost {:.6g}",
                     r0, lengthscale, r0_paper, lipschitz, r0 * lipschitz, incumbent_mean, worst_case);
}

CautiousnessReport cautiousness_report(const Surrogate& model, const Dataset& data, double gamma,
                                       ReportKernel kernel, Rng& rng, int probes) {
  CautiousnessReport rep;
  const Index d = data.dim();
  // The largest lengthscale gives the longest axis of the single-point ellipsoid: the worst-case step.
  double ell = 0;
  for (const Hyperparameter& h : model.hyperparameters())
    if (h.name.rfind("lengthscale", 0) == 0) ell = std::max(ell, h.value);
  rep.lengthscale = ell;
  rep.r0 = single_point_radius(kernel, ell, gamma);
  rep.r0_paper = paper_radius(ell, gamma);
  const Box box = Box::unit(d);
  double L = 0, best_mean = std::numeric_limits<double>::infinity();
  const Index n = data.size();
  const int per_point = n > 0 ? std::max(0, std::min<int>(probes, static_cast<int>(512 / std::max<Index>(n, 1)))) : 0;
  for (Index i = 0; i < n; ++i) {
    const Vec xi = data.X.row(i).transpose();
    const Prediction p = model.predict(xi, true);
    best_mean = std::min(best_mean, p.mean);
    if (p.has_gradient()) L = std::max(L, p.d_mean.norm());
    for (int k = 0; k < per_point && std::isfinite(rep.r0); ++k) {
      Vec u = rng.normal_vec(d);
      u /= std::max(u.norm(), 1e-300);
      const Prediction q = model.predict(box.clamp(xi + rng.uniform() * rep.r0 * u), true);
      if (q.has_gradient()) L = std::max(L, q.d_mean.norm());
    }
  }
  rep.lipschitz = L;
  rep.incumbent_mean = best_mean;
  // Eq. (5) for costs: the next trial is within r0 of some θ_k, so cost ≲ cost(θ_k) + r0·L; reported for the
  // incumbent (the evaluated point with the best mean, the usual neighbour of the next trial).
  rep.worst_case = best_mean + rep.r0 * L;
  return rep;
}

}  // namespace varbo
