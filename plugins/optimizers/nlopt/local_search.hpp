#pragma once
// One local NLopt run inside a region's box (and its constraint), maximizing f from one start and
// keeping the best feasible point it evaluated, whatever way NLopt stops.
#include <string>

#include "varbo/function.hpp"
#include "varbo/optimizer.hpp"
#include "varbo/region.hpp"

namespace varbo::nlopt_plugin {

enum class LocalMethod { Auto, Lbfgs, Slsqp, Mma, Cobyla, Bobyqa, NelderMead };

/// "lbfgs" -> LocalMethod::Lbfgs etc.; "auto" -> Auto. Throws ConfigError on an unknown name.
LocalMethod parse_method(const std::string& name);
std::string method_name(LocalMethod method);
/// The names accepted by parse_method except "auto".
const std::vector<std::string>& method_names();

struct LocalSettings {
  LocalMethod method = LocalMethod::Auto;
  Index max_evaluations = 200;
  double xtol_rel = 1e-7;
  double ftol_rel = 1e-9;
};

/// What actually runs for a requested method: gradient methods fall back to derivative-free ones when f has
/// no gradient (BOBYQA in a box, COBYLA with a constraint or in 1-D); methods that cannot handle a nonlinear
/// constraint fall back to SLSQP (with gradient) or COBYLA. Auto = L-BFGS in a box, SLSQP with a constraint.
LocalMethod effective_method(LocalMethod requested, bool has_gradient, bool constrained, Index dim);

/// Runs NLopt from x0 (clamped into the box). The result holds the best feasible point seen (value −inf and
/// success = false when none was finite and feasible). Never throws on NaN/inf values of f or NLopt failures.
OptimizeResult local_maximize(const DifferentiableFunction& f, const RegionConstraint& region, const Vec& x0,
                              const LocalSettings& settings);

/// Value of f at x without gradient, −inf for NaN/inf values or numerical errors thrown by f.
double safe_value(const DifferentiableFunction& f, const Vec& x);

}  // namespace varbo::nlopt_plugin
