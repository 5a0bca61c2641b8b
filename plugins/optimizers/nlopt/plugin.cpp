// libvarbo_nlopt.so: NLopt local optimizer, multi-start acquisition search and random search.
#include "optimizers.hpp"
#include "varbo/plugin.hpp"

namespace {
using varbo::nlopt_plugin::LocalSettings;
using varbo::nlopt_plugin::parse_method;

std::vector<std::string> with_auto(std::vector<std::string> names) {
  names.insert(names.begin(), "auto");
  return names;
}

LocalSettings local_settings(const varbo::Options& o, const std::string& method_key) {
  LocalSettings s;
  s.method = parse_method(o.str(method_key));
  s.max_evaluations = o.integer("max_evaluations");
  s.xtol_rel = o.real("xtol_rel");
  s.ftol_rel = o.real("ftol_rel");
  return s;
}

std::vector<varbo::OptionSpec> tolerance_options(long max_evaluations, double xtol, double ftol) {
  namespace opt = varbo::opt;
  return {opt::integer("max_evaluations", max_evaluations, "function evaluations per local run").at_least(1),
          opt::real("xtol_rel", xtol, "relative tolerance on θ of a local run").at_least(0),
          opt::real("ftol_rel", ftol, "relative tolerance on the value of a local run").at_least(0)};
}
}  // namespace

VARBO_PLUGIN("nlopt", "0.1.0", "NLopt local optimizers, multi-start and random search over a region") {
  using varbo::BuildContext;
  using varbo::Optimizer;
  using varbo::Options;
  namespace opt = varbo::opt;
  namespace np = varbo::nlopt_plugin;
  const std::vector<std::string> constraints{"optimizer:constraints"};

  auto nlopt_options = tolerance_options(500, 1e-8, 1e-10);
  nlopt_options.insert(nlopt_options.begin(),
                       opt::choice("algorithm", "slsqp", np::method_names(),
                                   "NLopt local method; gradient methods fall back to BOBYQA/COBYLA without a "
                                   "gradient, and methods without constraint support to SLSQP/COBYLA"));
  registry.add(varbo::make_component<Optimizer>(
      "nlopt", "a local NLopt method run from every start, inside the region's box and constraint", nlopt_options,
      varbo::Factory<Optimizer>([](const Options& o, const BuildContext&) {
        return std::make_unique<np::NloptOptimizer>(local_settings(o, "algorithm"));
      }),
      constraints));

  auto multistart_options = tolerance_options(200, 1e-7, 1e-9);
  multistart_options.insert(
      multistart_options.begin(),
      {opt::integer("candidates", 2000, "scrambled Sobol candidates evaluated without gradients").at_least(1),
       opt::integer("polish", 10, "best candidates refined by the local method").at_least(0),
       opt::choice("local", "auto", with_auto(np::method_names()),
                   "local method for the polish; auto = lbfgs in a box, slsqp with a constraint")});
  registry.add(varbo::make_component<Optimizer>(
      "multistart", "quasi-random candidates plus the region's seeds, the best few polished in parallel",
      multistart_options, varbo::Factory<Optimizer>([](const Options& o, const BuildContext&) {
        np::MultistartSettings s;
        s.candidates = o.integer("candidates");
        s.polish = o.integer("polish");
        s.local = local_settings(o, "local");
        return std::make_unique<np::MultistartOptimizer>(s);
      }),
      constraints));

  registry.add(varbo::make_component<Optimizer>(
      "random_search", "best of uniform random points in the region",
      {opt::integer("samples", 2000, "uniform points drawn in the box").at_least(1)},
      varbo::Factory<Optimizer>([](const Options& o, const BuildContext&) {
        return std::make_unique<np::RandomSearchOptimizer>(o.integer("samples"));
      }),
      constraints));
}
