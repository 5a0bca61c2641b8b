// Out-of-line destructors (vtables and typeinfo live in libvarbo_core) and small shared defaults.
#include <fmt/format.h>

#include <cmath>
#include <limits>

#include "varbo/acquisition.hpp"
#include "varbo/algorithm.hpp"
#include "varbo/continuation.hpp"
#include "varbo/errors.hpp"
#include "varbo/function.hpp"
#include "varbo/optimizer.hpp"
#include "varbo/region.hpp"
#include "varbo/sampler.hpp"
#include "varbo/surrogate.hpp"
#include "varbo/task.hpp"
#include "varbo/side_cap.hpp"
#include "varbo/value_stall.hpp"

namespace varbo {

DifferentiableFunction::~DifferentiableFunction() = default;
Surrogate::~Surrogate() = default;
MeanPrediction::~MeanPrediction() = default;

double posterior_mean(const Surrogate& model, const Vec& x) {
  if (const auto* m = dynamic_cast<const MeanPrediction*>(&model)) return m->predict_mean(x);
  return model.predict(x, false).mean;
}
Acquisition::~Acquisition() = default;
RegionConstraint::~RegionConstraint() = default;
FreshStartRegion::~FreshStartRegion() = default;
ValueStallRegion::~ValueStallRegion() = default;
SideCapRegion::~SideCapRegion() = default;
Sampler::~Sampler() = default;
Optimizer::~Optimizer() = default;
Task::~Task() = default;
TrialAware::~TrialAware() = default;
Algorithm::~Algorithm() = default;
ComponentExtension::~ComponentExtension() = default;
RunContinuation::~RunContinuation() = default;

void Surrogate::set_state(const std::string& name, const Vec&) {
  throw ConfigError("this surrogate has no state named '" + name + "'");
}

std::string FitReport::report() const {
  return fmt::format("{} {} objective {:.6g} (log-likelihood {:.6g}, log-prior {:.6g}), restarts {} ({} failed), "
                     "{:.3f} s{}{}",
                     ok ? "ok" : "FAILED", optimized ? "fit" : "conditioned", objective, log_likelihood, log_prior,
                     restarts, restarts_failed, seconds, message.empty() ? "" : ": ", message);
}

void RegionConstraint::update(const Surrogate*, const Dataset&, Rng&) {}

double RegionConstraint::constraint(const Vec& x, Vec* grad) const {
  if (grad) *grad = Vec::Zero(x.size());
  return 1.0;
}

bool RegionConstraint::contains(const Vec& x, double tol) const {
  if (!bounds().contains(x, tol)) return false;
  return !has_constraint() || constraint(x, nullptr) >= -tol;
}

Incumbent find_incumbent(const Surrogate& model, const Dataset& data, double kappa) {
  Incumbent best;
  double best_value = std::numeric_limits<double>::infinity();
  for (Index i = 0; i < data.size(); ++i) {
    const Prediction p = model.predict(data.X.row(i).transpose(), false);
    const double s = p.total_std();
    const double v = p.mean + kappa * s;
    if (v < best_value) {
      best_value = v;
      best = Incumbent{i, p.mean, s};
    }
  }
  if (best.index < 0 && data.size() > 0) {
    // No finite value at any point (a model overflowed by costs beyond ~1e154, whose squares a double cannot
    // hold): the lowest observation, as it is. An index of -1 reached callers that index the data with it
    // (Study::select segfaulted, or answered an empty θ).
    Index i = 0;
    data.y.minCoeff(&i);
    best = Incumbent{i, data.y[i], 0.0};
  }
  return best;
}

GradientCheck check_gradient(const DifferentiableFunction& f, const Vec& x, double h, double floor) {
  GradientCheck r;
  f.value(x, &r.analytic);
  r.numeric.resize(x.size());
  for (Index i = 0; i < x.size(); ++i) {
    const double step = h * std::max(1.0, std::abs(x[i]));
    Vec xp = x, xm = x;
    xp[i] += step;
    xm[i] -= step;
    r.numeric[i] = (f.value(xp, nullptr) - f.value(xm, nullptr)) / (2 * step);
  }
  for (Index i = 0; i < x.size(); ++i) {
    const double a = r.analytic[i], n = r.numeric[i];
    const double abs_err = std::abs(a - n);
    r.max_abs_error = std::max(r.max_abs_error, abs_err);
    r.max_rel_error = std::max(r.max_rel_error, abs_err / std::max({std::abs(a), std::abs(n), floor}));
  }
  return r;
}

}  // namespace varbo
