// libvarbo_rssgd: risk-sensitive stochastic gradient descent (Kuindersma 2013, Algorithm 3).
#include "continuation.hpp"
#include "rssgd.hpp"
#include "varbo/errors.hpp"
#include "varbo/plugin.hpp"

VARBO_PLUGIN("rssgd", "0.1.0", "Risk-sensitive stochastic gradient descent with a local surrogate critic") {
  varbo::ComponentInfo info = varbo::make_component<varbo::Algorithm>(
      "rssgd",
      "local policy search (Kuindersma 2013, Alg. 3): perturb θ by z ~ N(0, σ²), refit a critic surrogate on the "
      "observations within ε of θ, step θ -= (η/r̃θ)(Ĵθ+z − J̃θ + κ(r̃θ+z − r̃θ)) z; κ may follow a schedule",
      varbo::rssgd::options(), [](const varbo::Options& o, const varbo::BuildContext& ctx) {
        using namespace varbo;
        if (ctx.dim < 1) throw ConfigError("rssgd: the problem dimension must be at least 1");
        rssgd::Settings s = rssgd::settings_from(o, ctx.dim);
        Vec start = Vec::Constant(ctx.dim, 0.5);
        if (ctx.initial_point) start = *ctx.initial_point;
        if (o.is_set("start")) {
          const std::vector<double> v = o.reals("start");
          if (static_cast<Index>(v.size()) != ctx.dim)
            o.node("start").fail("expected one value per dimension, in the unit cube");
          start = Eigen::Map<const Vec>(v.data(), ctx.dim);
          if (!Box::unit(ctx.dim).contains(start)) o.node("start").fail("the start lies outside the unit cube");
        }
        Dataset history;
        if (o.is_set("history") && !o.str("history").empty()) history = rssgd::read_history(o.str("history"), ctx.dim);
        auto critic = ctx.registry->create<Surrogate>(o.component("critic"), ctx);
        return std::make_unique<rssgd::Rssgd>(std::move(s), std::move(critic), start, ctx.seed, std::move(history));
      });
  // `varbo rescore` continues a run with rssgd through this extension (varbo/continuation.hpp).
  info.extensions.push_back(std::make_shared<varbo::rssgd::Continuation>());
  registry.add(std::move(info));
}
