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
  // A surrogate that names no `lengthscale` hyperparameter (a third party's): r0 is unknown, not 0 (it printed
  // "single-point r0 0 ... (0 r0)"; red team, session 30).
  if (!(lengthscale > 0))
    return fmt::format("cautiousness: single-point r0 unknown (the surrogate names no lengthscale), region reach "
                       "{:.4g}, L {:.4g}, reach*L {:.4g}, incumbent mean {:.6g}, worst-case next cost {:.6g}",
                       reach, lipschitz, reach * lipschitz, incumbent_mean, worst_case);
  return fmt::format("cautiousness: single-point r0 {:.4g} (l_max {:.4g}; paper eq. 4: {:.4g}), region reach {:.4g} "
                     "({:.3g} r0), L {:.4g}, reach*L {:.4g}, incumbent mean {:.6g}, worst-case next cost {:.6g}",
                     single_point_r0, lengthscale, r0_paper, reach,
                     single_point_r0 > 0 ? reach / single_point_r0 : 0.0, lipschitz,
                     reach * lipschitz, incumbent_mean, worst_case);
}

namespace {

double distance_to_nearest(const Mat& X, const Vec& x) {
  return std::sqrt((X.rowwise() - x.transpose()).rowwise().squaredNorm().minCoeff());
}

/// The farthest region point (from the nearest data point) found on `rays` rays from the data points.
double measure_reach(const Surrogate& model, const Dataset& data, double threshold, double r0, Rng& rng, int rays) {
  const Index d = data.dim(), n = data.size();
  const Box box = Box::unit(d);
  auto inside = [&](const Vec& x) { return model.predict(x, false).latent_var <= threshold; };
  // Steps of r0/2 up to 4·r0 (r0 infinite or 0 — γ ≥ 1 or a degenerate lengthscale — : the box diagonal / 16).
  const double diagonal = std::sqrt(static_cast<double>(d));
  const double step = std::isfinite(r0) && r0 > 0 ? std::min(0.5 * r0, diagonal / 8) : diagonal / 16;
  const double far = std::min(8 * step, diagonal);
  double reach = 0;
  for (int j = 0; j < rays; ++j) {
    const Vec xi = data.X.row(j % n).transpose();
    Vec u = rng.normal_vec(d);
    u /= std::max(u.norm(), 1e-300);
    double last_in = 0, first_out = -1;
    for (double t = step; t <= far + 1e-12; t += step) {
      const Vec x = xi + t * u;
      if ((box.clamp(x) - x).norm() > 0 || !inside(x)) {
        first_out = t;
        break;
      }
      last_in = t;
    }
    if (first_out > 0)
      for (int b = 0; b < 6; ++b) {  // the boundary to 1/64 of a step
        const double t = 0.5 * (last_in + first_out);
        const Vec x = xi + t * u;
        if ((box.clamp(x) - x).norm() == 0 && inside(x)) last_in = t;
        else first_out = t;
      }
    if (last_in > 0) reach = std::max(reach, distance_to_nearest(data.X, xi + last_in * u));
  }
  return reach;
}

}  // namespace

CautiousnessReport cautiousness_report(const Surrogate& model, const Dataset& data, double gamma,
                                       ReportKernel kernel, Rng& rng, int probes) {
  CautiousnessReport rep;
  const Index d = data.dim();
  // The largest lengthscale gives the longest axis of the single-point ellipsoid: the worst-case step.
  double ell = 0;
  for (const Hyperparameter& h : model.hyperparameters())
    if (h.name.rfind("lengthscale", 0) == 0) ell = std::max(ell, h.value);
  rep.lengthscale = ell;
  rep.single_point_r0 = single_point_radius(kernel, ell, gamma);
  rep.r0_paper = paper_radius(ell, gamma);
  const Index n = data.size();
  if (n > 0) {
    Rng reach_rng = rng.stream(0x4eac);
    const int rays = static_cast<int>(std::max<Index>(std::min<Index>(256, std::max<Index>(probes, 1) * n), 1));
    rep.reach = measure_reach(model, data, gamma * gamma * model.signal_variance(), rep.single_point_r0, reach_rng,
                              rays);
  }
  const double probe_radius = std::isfinite(rep.single_point_r0) ? std::max(rep.single_point_r0, rep.reach) : rep.reach;
  const Box box = Box::unit(d);
  double L = 0, best_mean = std::numeric_limits<double>::infinity();
  const int per_point = n > 0 ? std::max(0, std::min<int>(probes, static_cast<int>(512 / std::max<Index>(n, 1)))) : 0;
  for (Index i = 0; i < n; ++i) {
    const Vec xi = data.X.row(i).transpose();
    const Prediction p = model.predict(xi, true);
    best_mean = std::min(best_mean, p.mean);
    if (p.has_gradient()) L = std::max(L, p.d_mean.norm());
    for (int k = 0; k < per_point; ++k) {
      Vec u = rng.normal_vec(d);
      u /= std::max(u.norm(), 1e-300);
      const Prediction q = model.predict(box.clamp(xi + rng.uniform() * probe_radius * u), true);
      if (q.has_gradient()) L = std::max(L, q.d_mean.norm());
    }
  }
  rep.lipschitz = L;
  rep.incumbent_mean = best_mean;
  // Eq. (5) for costs: the next trial is within `reach` of some θ_k, so cost ≲ cost(θ_k) + reach·L; reported for
  // the incumbent (the evaluated point with the best mean, the usual neighbour of the next trial). The paper's
  // r0 would understate it: with several points the region reaches farther than r0 (issue 12, item 10).
  rep.worst_case = best_mean + rep.reach * L;
  return rep;
}

}  // namespace varbo
