// libvarbo_nlopt.so: NLopt local optimizer, multi-start acquisition search and random search.
#include "optimizers.hpp"
#include "varbo/option_set.hpp"
#include "varbo/plugin.hpp"

namespace {
namespace np = varbo::nlopt_plugin;
namespace opt = varbo::opt;
using np::LocalMethod;
using np::LocalSettings;

/// {name, method} for every name parse_method accepts, `auto` first when asked for.
std::vector<std::pair<std::string, LocalMethod>> method_mapping(bool with_auto) {
  std::vector<std::pair<std::string, LocalMethod>> out;
  if (with_auto) out.emplace_back("auto", LocalMethod::Auto);
  for (const auto& n : np::method_names()) out.emplace_back(n, np::parse_method(n));
  return out;
}

/// The tolerance options of a local run, bound to the LocalSettings `local` of S.
template <class S>
void add_tolerance_options(varbo::OptionSet<S>& set) {
  set.add(opt::integer("max_evaluations", opt::nested(&S::local, &LocalSettings::max_evaluations),
                       "function evaluations per local run")
              .at_least(1))
      .add(opt::real("xtol_rel", opt::nested(&S::local, &LocalSettings::xtol_rel),
                     "relative tolerance on θ of a local run")
               .at_least(0))
      .add(opt::real("ftol_rel", opt::nested(&S::local, &LocalSettings::ftol_rel),
                     "relative tolerance on the value of a local run")
               .at_least(0));
}

const varbo::OptionSet<np::NloptSettings>& nlopt_options() {
  static const varbo::OptionSet<np::NloptSettings> set = [] {
    varbo::OptionSet<np::NloptSettings> s{
        opt::choice("algorithm", opt::nested(&np::NloptSettings::local, &LocalSettings::method), method_mapping(false),
                    "NLopt local method; gradient methods fall back to BOBYQA/COBYLA without a "
                    "gradient, and methods without constraint support to SLSQP/COBYLA")};
    add_tolerance_options(s);
    return s;
  }();
  return set;
}

const varbo::OptionSet<np::MultistartSettings>& multistart_options() {
  static const varbo::OptionSet<np::MultistartSettings> set = [] {
    varbo::OptionSet<np::MultistartSettings> s{
        opt::integer("candidates", &np::MultistartSettings::candidates,
                     "scrambled Sobol candidates evaluated without gradients (at most 10^6: they are held in memory "
                     "at once; 4e12 aborted a run with bad_alloc)")
            .at_least(1)
            .at_most(1e6),
        opt::integer("polish", &np::MultistartSettings::polish, "best candidates refined by the local method")
            .at_least(0),
        opt::choice("local", opt::nested(&np::MultistartSettings::local, &LocalSettings::method), method_mapping(true),
                    "local method for the polish; auto = lbfgs in a box, slsqp with a constraint")};
    add_tolerance_options(s);
    return s;
  }();
  return set;
}

const varbo::OptionSet<np::RandomSearchSettings>& random_search_options() {
  static const varbo::OptionSet<np::RandomSearchSettings> set{
      opt::integer("samples", &np::RandomSearchSettings::samples,
                   "uniform points drawn in the box (at most 10^6: they are held in memory at once)")
          .at_least(1)
          .at_most(1e6)};
  return set;
}
}  // namespace

VARBO_PLUGIN("nlopt", "0.1.0", "NLopt local optimizers, multi-start and random search over a region") {
  using varbo::BuildContext;
  using varbo::Optimizer;
  using varbo::Options;
  const std::vector<std::string> constraints{"optimizer:constraints"};

  registry.add(varbo::make_component<Optimizer>(
      "nlopt", "a local NLopt method run from every start, inside the region's box and constraint",
      nlopt_options().specs(), varbo::Factory<Optimizer>([](const Options& o, const BuildContext&) {
        return std::make_unique<np::NloptOptimizer>(nlopt_options().read(o).local);
      }),
      constraints));

  registry.add(varbo::make_component<Optimizer>(
      "multistart", "quasi-random candidates plus the region's seeds, the best few polished in parallel",
      multistart_options().specs(), varbo::Factory<Optimizer>([](const Options& o, const BuildContext&) {
        return std::make_unique<np::MultistartOptimizer>(multistart_options().read(o));
      }),
      constraints));

  registry.add(varbo::make_component<Optimizer>(
      "random_search", "best of uniform random points in the region", random_search_options().specs(),
      varbo::Factory<Optimizer>([](const Options& o, const BuildContext&) {
        return std::make_unique<np::RandomSearchOptimizer>(random_search_options().read(o).samples);
      }),
      constraints));
}
