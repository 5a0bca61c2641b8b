#include "ceres_lbfgs.hpp"
#include "varbo/option_set.hpp"
#include "varbo/plugin.hpp"

namespace {
using varbo::ceres_lbfgs::LbfgsSettings;
namespace opt = varbo::opt;
const varbo::OptionSet<LbfgsSettings>& lbfgs_options() {
  static const varbo::OptionSet<LbfgsSettings> set{
      opt::integer("max_iterations", &LbfgsSettings::max_iterations, "maximum L-BFGS iterations per start").at_least(1),
      opt::real("function_tolerance", &LbfgsSettings::function_tolerance,
                "stop when the relative change of the value falls below this")
          .above(0),
      opt::real("gradient_tolerance", &LbfgsSettings::gradient_tolerance,
                "stop when the projected gradient norm falls below this")
          .above(0),
      opt::real("parameter_tolerance", &LbfgsSettings::parameter_tolerance,
                "stop when the relative step falls below this")
          .above(0),
      opt::real("relative_gradient_tolerance", &LbfgsSettings::relative_gradient_tolerance,
                "a stop on function_tolerance or parameter_tolerance counts only when max |df/dx_i| <= this * "
                "max(1, |f|); otherwise L-BFGS restarts from there (within max_iterations)")
          .above(0),
      opt::integer("lbfgs_rank", &LbfgsSettings::lbfgs_rank, "number of L-BFGS correction pairs").at_least(1)};
  return set;
}
}  // namespace

VARBO_PLUGIN("ceres_lbfgs", "0.1.0", "L-BFGS line search from Ceres' GradientProblemSolver") {
  using namespace varbo;
  registry.add(make_component<Optimizer>(
      "ceres_lbfgs",
      "Unconstrained L-BFGS line search (Ceres GradientProblemSolver) from each given start, keeping the "
      "best. It IGNORES the region's box and cannot honour constraints: meant for smooth unconstrained "
      "problems such as GP hyperparameter fits in log space. Non-finite values are treated as failed "
      "evaluations; without an analytic gradient, central finite differences are used.",
      lbfgs_options().specs(),
      Factory<Optimizer>([](const Options& o, const BuildContext&) -> std::unique_ptr<Optimizer> {
        return std::make_unique<ceres_lbfgs::CeresLbfgs>(lbfgs_options().read(o));
      }),
      {},
      // Only for problems without bounds (hyperparameter fits); never an acquisition search in a box.
      {"problem:unbounded"}));
}
