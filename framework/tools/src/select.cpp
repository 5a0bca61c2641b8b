// Risk-sensitive policy selection on a fitted model (Kuindersma 2013, section 3.2, eq. 20).
#include "varbo/select.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <limits>
#include <optional>
#include <cmath>
#include <stdexcept>

#include "varbo/away_from_failures.hpp"
#include "varbo/errors.hpp"
#include "varbo/math.hpp"
#include "varbo/space_wrappers.hpp"

namespace varbo {

NegativeConfidenceBound::NegativeConfidenceBound(const Surrogate& model, Index dim, double kappa)
    : model_(model), dim_(dim), kappa_(kappa) {
  gradients_ = model_.predict(Vec::Constant(dim, 0.5), true).has_gradient();
}

double NegativeConfidenceBound::value(const Vec& x, Vec* grad) const {
  const Prediction p = model_.predict(x, grad != nullptr);
  // s = sqrt(c*² + exp(μ* + σ*²/2)) (section 2.2); ds/dx = dV/dx / (2 s).
  const double s = p.total_std();
  if (grad != nullptr) {
    if (!p.has_gradient()) throw NumericalError("-(E + kappa s): the model gave no gradient");
    const Vec d_std = p.d_total_var() / (2.0 * std::max(s, 1e-300));
    *grad = -(p.d_mean + kappa_ * d_std);
  }
  return -(p.mean + kappa_ * s);
}

double relative_latent_std(const Surrogate& model, const Prediction& p) {
  return std::sqrt(std::max(0.0, p.latent_var) / std::max(model.signal_variance(), 1e-300));
}

namespace {
// Fills the selection for κ at x (unit cube) from the model's prediction there.
void describe_at(RiskSelection& r, const Surrogate& model, const Domain& domain, const Vec& x, const Prediction& p,
                 const SharedSpace& space) {
  r.x = x;
  r.mean = p.mean;
  r.std = p.total_std();
  r.criterion = r.mean + r.kappa * r.std;
  r.relative_latent_std = relative_latent_std(model, p);
  r.theta = space ? space->decode(r.x) : from_unit(r.x, domain.box);
  r.ok = std::isfinite(r.criterion);
}

// One selection per κ; a non-finite κ gets a message, the others `choose`.
template <class Choose>
std::vector<RiskSelection> for_each_kappa(const std::vector<double>& kappas, Choose choose) {
  std::vector<RiskSelection> out;
  out.reserve(kappas.size());
  for (double kappa : kappas) {
    RiskSelection r;
    r.kappa = kappa;
    if (std::isfinite(kappa)) choose(r);
    else r.message = "kappa is not finite";
    out.push_back(std::move(r));
  }
  return out;
}
}  // namespace

std::vector<RiskSelection> select_policies(const Surrogate& model, const Domain& domain,
                                           const std::vector<double>& kappas, const Optimizer& optimizer,
                                           const Rng& rng, const Mat& starts, const SharedSpace& space,
                                           const Mat& failed) {
  if (!model.ready()) throw InputError("select: the model is not fitted (no data?)");
  const Index d = space ? space->encoded_dim() : domain.box.dim();
  if (d < 1) throw InputError("select: the domain has no parameters");
  if (starts.size() > 0 && starts.cols() != d)
    throw InputError(fmt::format("select: starting points have {} columns, the domain {}", starts.cols(), d));
  if (failed.rows() > 0 && (failed.cols() != d || starts.rows() == 0))
    throw InputError(fmt::format("select: {} failed points of dimension {} with {} successful ones; the domain has {}",
                                 failed.rows(), failed.cols(), starts.rows(), d));
  const std::unique_ptr<RegionConstraint> unit = respect_constraints(std::make_unique<BoxRegion>(Box::unit(d)), space);
  std::optional<AwayFromFailures> away;
  if (failed.rows() > 0) away.emplace(*unit, starts, failed);
  const RegionConstraint& region = away ? static_cast<const RegionConstraint&>(*away) : *unit;
  return for_each_kappa(kappas, [&](RiskSelection& r) {
    const NegativeConfidenceBound f(model, d, r.kappa);
    // The stream depends only on κ's value: selecting [2, -2] or [-2] gives the same answer for -2.
    Rng krng = rng.stream(0x5e1ec7, std::bit_cast<std::uint64_t>(r.kappa == 0.0 ? 0.0 : r.kappa));
    OptimizeResult res;
    try {
      res = optimizer.maximize(f, region, starts, krng);
    } catch (const std::exception& e) {
      res.success = false;
      res.message = e.what();
    }
    if (res.x.size() != d || !res.x.allFinite()) {
      r.message = fmt::format("the optimizer found no point ({})", res.message);
      return;
    }
    Vec x = space ? space->admissible(res.x) : Vec(Box::unit(d).clamp(res.x));
    std::string note;
    if (away && away->constraint(x, nullptr) < -1e-9) {
      // The optimizer's point (or its admissible rounding) lies nearer a failure: the best successful trial instead.
      Index best = 0;
      double best_value = std::numeric_limits<double>::infinity();
      for (Index i = 0; i < starts.rows(); ++i) {
        const double v = -f.value(starts.row(i).transpose(), nullptr);
        if (v < best_value) best_value = v, best = i;
      }
      x = starts.row(best).transpose();
      note = "; the optimizer's point lay too near a failed trial: the best successful trial";
    } else if (starts.rows() > 0) {
      // Never worse than where it started: an optimizer that ignores the box (ceres_lbfgs) ran outside it, and its
      // point clamped back scored far worse than the starts (0.78 against −0.02; red team, session 26).
      Index best = -1;
      double best_value = -f.value(x, nullptr);
      for (Index i = 0; i < starts.rows(); ++i) {
        const double v = -f.value(starts.row(i).transpose(), nullptr);
        if (v < best_value) best_value = v, best = i;
      }
      if (best >= 0) {
        x = starts.row(best).transpose();
        note = "; the optimizer's point (clamped into the domain) scored worse than a start: the best start";
      }
    }
    describe_at(r, model, domain, x, model.predict(x, false), space);
    r.message = r.ok ? res.message + note : "non-finite prediction at the optimizer's point";
  });
}

}  // namespace varbo

namespace varbo {

std::vector<RiskSelection> select_among(const Surrogate& model, const Domain& domain,
                                        const std::vector<double>& kappas, const Mat& points, const SharedSpace& space) {
  if (!model.ready()) throw InputError("select: the model is not fitted (no data?)");
  const Index d = space ? space->encoded_dim() : domain.box.dim();
  if (points.rows() == 0 || points.cols() != d)
    throw InputError(fmt::format("select: {} candidate points of dimension {}, the domain has {}", points.rows(),
                                 points.cols(), d));
  std::vector<Prediction> p;
  for (Index i = 0; i < points.rows(); ++i) p.push_back(model.predict(points.row(i).transpose(), false));
  return for_each_kappa(kappas, [&](RiskSelection& r) {
    Index best = -1;
    double best_value = std::numeric_limits<double>::infinity();
    for (Index i = 0; i < points.rows(); ++i) {
      const Prediction& q = p[static_cast<std::size_t>(i)];
      const double v = q.mean + r.kappa * q.total_std();
      if (v < best_value) best_value = v, best = i;
    }
    if (best < 0) {
      r.message = "no candidate has a finite E + kappa*s";
      return;
    }
    describe_at(r, model, domain, points.row(best).transpose(), p[static_cast<std::size_t>(best)], space);
  });
}

}  // namespace varbo
