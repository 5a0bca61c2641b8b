#include "local_search.hpp"

#include <fmt/format.h>

#include <atomic>
#include <cmath>
#include <exception>
#include <limits>
#include <nlopt.hpp>

#include "varbo/errors.hpp"
#include "varbo/log.hpp"

namespace varbo::nlopt_plugin {

namespace {

constexpr double kNegInf = -std::numeric_limits<double>::infinity();
// What NLopt sees for a NaN/inf value of f: a finite, very bad value, so line searches back off and
// derivative-free methods move away instead of stopping on a NaN comparison.
constexpr double kBadValue = -1e100;
constexpr double kConstraintTolerance = 1e-10;

// Constrained methods converge to the boundary from either side, within their tolerance: points this
// close to feasible are remembered and moved inside afterwards (repair_into_constraint).
constexpr double kRepairTolerance = 1e-6;

struct Tracker {
  const DifferentiableFunction* f = nullptr;
  const RegionConstraint* region = nullptr;
  OptimizeResult best;          ///< best strictly feasible point
  OptimizeResult near_feasible; ///< best point with −kRepairTolerance ≤ c(x) < 0
  Index evaluations = 0;
  std::exception_ptr raised;  ///< what the function threw (not a NumericalError): the search stops there
};

Vec clamp_to(const Box& box, const double* x, unsigned n) {
  Vec v(static_cast<Index>(n));
  for (unsigned i = 0; i < n; ++i) v[i] = x[i];
  return box.clamp(v);
}

double objective(unsigned n, const double* x, double* grad, void* data) {
  auto& t = *static_cast<Tracker*>(data);
  const Vec xv = clamp_to(t.region->bounds(), x, n);
  Vec g;
  double v;
  try {
    v = t.f->value(xv, grad ? &g : nullptr);
  } catch (const NumericalError&) {
    v = std::numeric_limits<double>::quiet_NaN();
  } catch (...) {
    // The acquisition or its model threw (a third-party surrogate's predict, say): kept and handled after NLopt
    // returns (local_maximize), not thrown through NLopt's C frames. It was swallowed with NLopt's own failures
    // before, and the run went on in silence with other trials (red team, session 46).
    if (!t.raised) t.raised = std::current_exception();
    throw nlopt::forced_stop();
  }
  ++t.evaluations;
  if (!std::isfinite(v)) {
    if (grad)
      for (unsigned i = 0; i < n; ++i) grad[i] = 0;
    return kBadValue;
  }
  if (grad) {
    for (unsigned i = 0; i < n; ++i) grad[i] = (g.size() == static_cast<Index>(n) && std::isfinite(g[i])) ? g[i] : 0;
  }
  if (v > t.best.value) {
    const double c = t.region->has_constraint() ? t.region->constraint(xv, nullptr) : 0.0;
    if (c >= 0) {
      t.best.value = v;
      t.best.x = xv;
    } else if (c >= -kRepairTolerance && v > t.near_feasible.value) {
      t.near_feasible.value = v;
      t.near_feasible.x = xv;
    }
  }
  return v;
}

// NLopt's form fc(x) ≤ 0 of the region's c(x) ≥ 0.
double constraint(unsigned n, const double* x, double* grad, void* data) {
  auto& t = *static_cast<Tracker*>(data);
  const Vec xv = clamp_to(t.region->bounds(), x, n);
  Vec g;
  const double c = t.region->constraint(xv, grad ? &g : nullptr);
  if (grad)
    for (unsigned i = 0; i < n; ++i) grad[i] = (g.size() == static_cast<Index>(n) && std::isfinite(g[i])) ? -g[i] : 0;
  return std::isfinite(c) ? -c : 1e100;
}

nlopt::algorithm to_nlopt(LocalMethod m) {
  switch (m) {
    case LocalMethod::Lbfgs: return nlopt::LD_LBFGS;
    case LocalMethod::Slsqp: return nlopt::LD_SLSQP;
    case LocalMethod::Mma: return nlopt::LD_MMA;
    case LocalMethod::Cobyla: return nlopt::LN_COBYLA;
    case LocalMethod::Bobyqa: return nlopt::LN_BOBYQA;
    case LocalMethod::NelderMead: return nlopt::LN_NELDERMEAD;
    case LocalMethod::Auto: break;
  }
  return nlopt::LD_LBFGS;
}

bool needs_gradient(LocalMethod m) {
  return m == LocalMethod::Lbfgs || m == LocalMethod::Slsqp || m == LocalMethod::Mma;
}
bool handles_constraint(LocalMethod m) {
  return m == LocalMethod::Slsqp || m == LocalMethod::Mma || m == LocalMethod::Cobyla;
}

// Moves a slightly infeasible point onto the feasible side by Newton steps along ∇c (c(x + α∇c) ≈ c + α|∇c|²),
// then keeps it if it beats the best strictly feasible point.
void repair_into_constraint(Tracker& t) {
  if (!(t.near_feasible.value > t.best.value)) return;
  const Box& box = t.region->bounds();
  Vec x = t.near_feasible.x;
  for (int step = 0; step < 5; ++step) {
    Vec g;
    const double c = t.region->constraint(x, &g);
    if (c >= 0 || !std::isfinite(c)) break;
    const double g2 = g.squaredNorm();
    if (!(g2 > 0) || !std::isfinite(g2)) return;
    const double target = std::max(1e-12, 1e-3 * -c);  // aim a little inside
    x = box.clamp(x + (target - c) / g2 * g);
  }
  if (!t.region->contains(x)) return;
  const double v = safe_value(*t.f, x);
  ++t.evaluations;
  if (v > t.best.value) {
    t.best.value = v;
    t.best.x = x;
  }
}

}  // namespace

const std::vector<std::string>& method_names() {
  static const std::vector<std::string> names{"lbfgs", "slsqp", "mma", "cobyla", "bobyqa", "neldermead"};
  return names;
}

LocalMethod parse_method(const std::string& name) {
  if (name == "auto") return LocalMethod::Auto;
  if (name == "lbfgs") return LocalMethod::Lbfgs;
  if (name == "slsqp") return LocalMethod::Slsqp;
  if (name == "mma") return LocalMethod::Mma;
  if (name == "cobyla") return LocalMethod::Cobyla;
  if (name == "bobyqa") return LocalMethod::Bobyqa;
  if (name == "neldermead") return LocalMethod::NelderMead;
  throw ConfigError("unknown NLopt local method '" + name + "'; known: auto, lbfgs, slsqp, mma, cobyla, bobyqa, neldermead");
}

std::string method_name(LocalMethod m) {
  switch (m) {
    case LocalMethod::Auto: return "auto";
    case LocalMethod::Lbfgs: return "lbfgs";
    case LocalMethod::Slsqp: return "slsqp";
    case LocalMethod::Mma: return "mma";
    case LocalMethod::Cobyla: return "cobyla";
    case LocalMethod::Bobyqa: return "bobyqa";
    case LocalMethod::NelderMead: return "neldermead";
  }
  return "?";
}

LocalMethod effective_method(LocalMethod m, bool has_gradient, bool constrained, Index dim) {
  if (m == LocalMethod::Auto) m = constrained ? LocalMethod::Slsqp : LocalMethod::Lbfgs;
  if (constrained && !handles_constraint(m)) m = has_gradient ? LocalMethod::Slsqp : LocalMethod::Cobyla;
  if (!has_gradient && needs_gradient(m)) m = constrained ? LocalMethod::Cobyla : LocalMethod::Bobyqa;
  // NLopt's BOBYQA needs at least 2 variables.
  if (m == LocalMethod::Bobyqa && dim < 2) m = LocalMethod::Cobyla;
  return m;
}

double safe_value(const DifferentiableFunction& f, const Vec& x) {
  try {
    const double v = f.value(x, nullptr);
    return std::isfinite(v) ? v : kNegInf;
  } catch (const NumericalError&) {
    return kNegInf;
  }
}

OptimizeResult local_maximize(const DifferentiableFunction& f, const RegionConstraint& region, const Vec& x0,
                              const LocalSettings& settings) {
  const Box& box = region.bounds();
  const Index d = box.dim();
  const LocalMethod method = effective_method(settings.method, f.has_gradient(), region.has_constraint(), d);
  if (settings.method != LocalMethod::Auto && method != settings.method) {
    // A method the user chose by name and that cannot run here (a constraint it does not handle, no gradient,
    // BOBYQA in 1-D) is replaced; said once per process, not once per local run (red team, session 23: silent).
    static std::atomic<bool> said{false};
    if (!said.exchange(true))
      log_info("nlopt: local method '{}' cannot be used here ({}); '{}' is used instead", method_name(settings.method),
               region.has_constraint() && !handles_constraint(settings.method) ? "the region adds a constraint it does not handle"
               : !f.has_gradient() && needs_gradient(settings.method)          ? "it needs a gradient the function has not"
                                                                                : "it needs at least 2 variables",
               method_name(method));
  }
  Tracker t;
  t.f = &f;
  t.region = &region;
  t.best.x = box.clamp(x0);
  std::string message;
  try {
    nlopt::opt opt(to_nlopt(method), static_cast<unsigned>(d));
    opt.set_lower_bounds(std::vector<double>(box.lower.data(), box.lower.data() + d));
    opt.set_upper_bounds(std::vector<double>(box.upper.data(), box.upper.data() + d));
    opt.set_max_objective(objective, &t);
    if (region.has_constraint()) opt.add_inequality_constraint(constraint, &t, kConstraintTolerance);
    opt.set_maxeval(static_cast<int>(std::max<Index>(settings.max_evaluations, 1)));
    opt.set_xtol_rel(settings.xtol_rel);
    opt.set_ftol_rel(settings.ftol_rel);
    std::vector<double> x(t.best.x.data(), t.best.x.data() + d);
    double value = 0;
    const nlopt::result r = opt.optimize(x, value);
    message = fmt::format("{}: nlopt result {}", method_name(method), static_cast<int>(r));
  } catch (const std::exception& e) {
    // Roundoff-limited, forced stops and failures still leave the best point seen so far.
    message = fmt::format("{}: {}", method_name(method), e.what());
  }
  if (t.raised) {
    // A mistake in a component's code stops the run naming it (as ceres_lbfgs does); anything else the function
    // threw is said (once per process: a fault at some x repeats at every start) and the search keeps its best
    // point so far.
    try {
      std::rethrow_exception(t.raised);
    } catch (const PluginCodeError&) {
      throw;
    } catch (const std::exception& e) {
      message = fmt::format("{}: the function threw: {}", method_name(method), e.what());
    } catch (...) {
      message = fmt::format("{}: the function threw something that is not a std::exception", method_name(method));
    }
    static std::atomic<bool> said{false};
    if (!said.exchange(true))
      log_warn("nlopt: a local search of the acquisition stopped on an exception from the acquisition or its model "
               "({}); its best point so far is kept (said once)",
               message);
  }
  if (region.has_constraint()) repair_into_constraint(t);
  t.best.evaluations = t.evaluations;
  t.best.success = std::isfinite(t.best.value);
  t.best.message = message;
  return t.best;
}

}  // namespace varbo::nlopt_plugin
