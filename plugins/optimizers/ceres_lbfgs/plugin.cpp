#include "ceres_lbfgs.hpp"
#include "varbo/plugin.hpp"

VARBO_PLUGIN("ceres_lbfgs", "0.1.0", "L-BFGS line search from Ceres' GradientProblemSolver") {
  using namespace varbo;
  registry.add(make_component<Optimizer>(
      "ceres_lbfgs",
      "Unconstrained L-BFGS line search (Ceres GradientProblemSolver) from each given start, keeping the "
      "best. It IGNORES the region's box and cannot honour constraints: meant for smooth unconstrained "
      "problems such as GP hyperparameter fits in log space. Non-finite values are treated as failed "
      "evaluations; without an analytic gradient, central finite differences are used.",
      {opt::integer("max_iterations", 200, "maximum L-BFGS iterations per start").at_least(1),
       opt::real("function_tolerance", 1e-6, "stop when the relative change of the value falls below this")
           .above(0),
       opt::real("gradient_tolerance", 1e-10, "stop when the projected gradient norm falls below this").above(0),
       opt::real("parameter_tolerance", 1e-8, "stop when the relative step falls below this").above(0),
       opt::real("relative_gradient_tolerance", 1e-4,
                 "a stop on function_tolerance or parameter_tolerance counts only when max |df/dx_i| <= this * "
                 "max(1, |f|); otherwise L-BFGS restarts from there (within max_iterations)")
           .above(0),
       opt::integer("lbfgs_rank", 20, "number of L-BFGS correction pairs").at_least(1)},
      Factory<Optimizer>([](const Options& o, const BuildContext&) -> std::unique_ptr<Optimizer> {
        ceres_lbfgs::LbfgsSettings s;
        s.max_iterations = static_cast<int>(o.integer("max_iterations"));
        s.function_tolerance = o.real("function_tolerance");
        s.gradient_tolerance = o.real("gradient_tolerance");
        s.parameter_tolerance = o.real("parameter_tolerance");
        s.relative_gradient_tolerance = o.real("relative_gradient_tolerance");
        s.lbfgs_rank = static_cast<int>(o.integer("lbfgs_rank"));
        return std::make_unique<ceres_lbfgs::CeresLbfgs>(s);
      }),
      {},
      // Only for problems without bounds (hyperparameter fits); never an acquisition search in a box.
      {"problem:unbounded"}));
}
