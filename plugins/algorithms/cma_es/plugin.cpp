// Plugin `cma_es`: CMA-ES as an ask/tell algorithm (Hansen 2016 defaults), a baseline for CRBO.
#include <cmath>

#include <fmt/format.h>

#include "cma_es.hpp"
#include "varbo/log.hpp"
#include "varbo/errors.hpp"
#include "varbo/option_set.hpp"
#include "varbo/plugin.hpp"

namespace {
using varbo::CmaEsOptions;
namespace opt = varbo::opt;
const varbo::OptionSet<CmaEsOptions>& cma_es_options() {
  static const varbo::OptionSet<CmaEsOptions> set{
      opt::real("sigma0", &CmaEsOptions::sigma0, "initial step size (unit cube)").above(0),
      opt::reals("x0", "", "initial mean in the unit cube (default: the task's initial point, else the centre)"),
      opt::integer("population", &CmaEsOptions::population,
                   "lambda; 0 = 4 + floor(3 ln d) (at most 10^5: a generation is held in memory)")
          .at_least(0)
          .at_most(1e5),
      opt::real("penalty", &CmaEsOptions::penalty,
                "boundary penalty factor, times the generation's cost range per unit distance^2")
          .at_least(0),
      opt::choice("recommendation", &CmaEsOptions::recommend_mean, {{"best_observed", false}, {"mean", true}},
                  "the θ to deploy: the best observed candidate, or the distribution mean (better under noise)")};
  return set;
}
}  // namespace

VARBO_PLUGIN("cma_es", "0.1.0", "CMA-ES ask/tell algorithm with the tutorial's default parameters") {
  using namespace varbo;
  registry.add(make_component<Algorithm>(
      "cma_es",
      "CMA-ES (Hansen 2016 defaults) in the unit cube; out-of-box candidates are clipped and penalized",
      cma_es_options().specs(),
      [](const Options& o, const BuildContext& ctx) -> std::unique_ptr<Algorithm> {
        if (ctx.dim <= 0) throw ConfigError("algorithm 'cma_es' needs the problem dimension (got 0)");
        CmaEsOptions c = cma_es_options().read(o);
        c.seed = ctx.seed;
        // λ = 1 ran as λ = 2 in silence; a step below ~1e-9 of the cube made every generation degenerate and each
        // restart repeated it: the whole budget at one point (red team, session 27).
        if (c.population == 1)
          o.node("population").fail("expected 0 (the default 4 + floor(3 ln d)) or at least 2: CMA-ES ranks the "
                                    "candidates of a generation against each other");
        if (c.sigma0 < 1e-9)
          o.node("sigma0").fail(fmt::format("expected at least 1e-9 (the unit cube's width is 1), got {:g}: a step "
                                            "that small cannot move the mean",
                                            c.sigma0));
        if (o.is_set("x0")) {
          const std::vector<double> v = o.reals("x0");
          if (static_cast<Index>(v.size()) != ctx.dim)
            o.node("x0").fail("expected " + std::to_string(ctx.dim) + " values (one per dimension, unit cube)");
          c.x0 = Eigen::Map<const Vec>(v.data(), ctx.dim);
          if (!Box::unit(ctx.dim).contains(*c.x0)) o.node("x0").fail("expected values in [0, 1] (unit cube)");
        } else if (ctx.initial_point) {
          c.x0 = *ctx.initial_point;
        }
        const Index lambda =
            c.population > 0 ? c.population : 4 + static_cast<Index>(std::floor(3.0 * std::log(double(ctx.dim))));
        if (ctx.budget > 0 && lambda >= ctx.budget)
          // Accepted in silence before: the run was random sampling around x0 under CMA-ES's name.
          log_warn_once(fmt::format("{}cma_es: the population ({}) is at least the budget ({}): the first "
                                    "generation uses every trial, so CMA-ES never adapts its distribution",
                                    o.given("population") ? o.node("population").where() + ": " : std::string(),
                                    lambda, ctx.budget));
        return std::make_unique<CmaEs>(ctx.dim, c);
      },
      {"search_space:mixed"}));
}
