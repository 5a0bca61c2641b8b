#include "gp_component.hpp"

#include <cmath>

#include "gp_surrogate.hpp"
#include "transformed_surrogate.hpp"
#include "varbo/errors.hpp"

namespace varbo::gp {

namespace {

double finite_number(const ConfigNode& n) {
  double v = 0;
  try {
    v = n.yaml().as<double>();
  } catch (const YAML::Exception&) {
    n.fail("expected a number, got '" + (n.is_scalar() ? n.scalar() : std::string("a non-scalar")) + "'");
  }
  if (!std::isfinite(v)) n.fail("expected a finite number");
  return v;
}

void check_range(const Options& o, const std::string& lo, const std::string& hi) {
  if (!(o.real(lo) < o.real(hi)))
    o.node(hi).fail("gp: expected " + hi + " > " + lo + " (" + std::to_string(o.real(lo)) + ")");
}

}  // namespace

Hyperparameters parse_hyperparameters(const ConfigNode& node, Index dim) {
  Hyperparameters h;
  if (!node.defined()) return h;
  if (!node.is_map()) node.fail("expected a map of hyperparameter names to values");
  auto add = [&h](const std::string& name, const ConfigNode& n) {
    const double v = finite_number(n);
    if (name != "mean" && !(v > 0)) n.fail("expected a positive value for " + name);
    h.push_back({name, v});
  };
  for (const auto& key : node.keys()) {
    const ConfigNode v = node.child(key);
    if (key == "lengthscale" && v.is_sequence()) {
      if (static_cast<Index>(v.size()) != dim)
        v.fail("expected " + std::to_string(dim) + " lengthscales (one per dimension), got " +
               std::to_string(v.size()));
      for (std::size_t i = 0; i < v.size(); ++i) add("lengthscale[" + std::to_string(i) + "]", v.item(i));
    } else if (key == "lengthscale") {
      for (Index i = 0; i < dim; ++i) add("lengthscale[" + std::to_string(i) + "]", v);
    } else {
      add(key, v);
    }
  }
  return h;
}

ComponentInfo gp_component() {
  return make_component<Surrogate>(
      "gp",
      "Gaussian process with constant mean, standardized costs, SE-ARD or Matern-5/2-ARD kernel and "
      "Gaussian noise. Hyperparameters maximize the log marginal likelihood plus independent log-normal "
      "hyperpriors (Kuindersma 2013, eq. 13), with parallel random restarts of `fit_optimizer`.",
      {
          opt::choice("kernel", "matern52_ard", {"se_ard", "matern52_ard"}, "covariance function"),
          opt::integer("restarts", 4, "optimizer runs per fit (the first warm-started from the previous fit)")
              .at_least(1),
          opt::real("full_fit_growth", GpSettings{}.full_fit_growth,
                    "all restarts once N has grown by this factor since the last such fit (and always up to N = 20); "
                    "in between only the warm start (1: all restarts at every fit)")
              .at_least(1),
          opt::component("fit_optimizer", Kind::Optimizer, "{type: ceres_lbfgs, max_iterations: 100}",
                         "optimizer of the log posterior over log-hyperparameters"),
          opt::choice("prior_mean", "data_mean", {"data_mean", "max"},
                      "constant prior mean: the mean of the costs, or the largest cost (pessimistic: unexplored "
                      "regions look no better than the worst trial; De Ath et al. 2020)"),
          opt::boolean("priors", true, "add the log-normal hyperpriors to the objective (false: plain ML-II)"),
          opt::real("lengthscale_prior_median", 0.5, "median of the lengthscale prior (unit cube)").above(0),
          opt::real("lengthscale_prior_sd", 1.0, "sd of log lengthscale").above(0),
          opt::real("signal_std_prior_median", 1.0, "median of the signal std prior, relative to std(y)").above(0),
          opt::real("signal_std_prior_sd", 1.0, "sd of log signal std").above(0),
          opt::real("noise_std_prior_median", 0.01, "median of the noise std prior, relative to std(y)").above(0),
          opt::real("noise_std_prior_sd", 3.0, "sd of log noise std (wide: the data decide between noise-free and noisy)").above(0),
          opt::real("min_lengthscale", 0.01, "lower bound of each lengthscale (unit cube)").above(0),
          opt::real("max_lengthscale", 50.0, "upper bound of each lengthscale (unit cube)").above(0),
          opt::real("min_signal_std", 0.05, "lower bound of the signal std, relative to std(y)").above(0),
          opt::real("max_signal_std", 20.0, "upper bound of the signal std, relative to std(y)").above(0),
          opt::real("min_noise_std", 1e-6, "lower bound of the noise std, relative to std(y)").above(0),
          opt::real("max_noise_std", 2.0, "upper bound of the noise std, relative to std(y)").above(0),
          opt::choice("output_transform", "none", transforms::output_transform_names(),
                      transforms::output_transform_description()),
          opt::node("hyperparameters", "",
                    "initial (or, with `varbo fit --no-optimize`, fixed) values in natural units: lengthscale "
                    "(number or list), lengthscale[i], signal_std, noise_std (cost units), mean (fixes the "
                    "constant mean; otherwise it is the data mean)"),
      },
      Factory<Surrogate>([](const Options& o, const BuildContext& ctx) -> std::unique_ptr<Surrogate> {
        check_range(o, "min_lengthscale", "max_lengthscale");
        check_range(o, "min_signal_std", "max_signal_std");
        check_range(o, "min_noise_std", "max_noise_std");
        GpSettings s;
        try {
          s.kernel = kernels::parse_kernel_type(o.str("kernel"));
        } catch (const std::invalid_argument& e) {
          o.node("kernel").fail(e.what());
        }
        s.restarts = static_cast<int>(o.integer("restarts"));
        s.full_fit_growth = o.real("full_fit_growth");
        s.prior_mean = o.str("prior_mean") == "max" ? GpSettings::PriorMean::Max : GpSettings::PriorMean::DataMean;
        s.priors.enabled = o.boolean("priors");
        s.priors.lengthscale = {std::log(o.real("lengthscale_prior_median")), o.real("lengthscale_prior_sd")};
        s.priors.signal_std = {std::log(o.real("signal_std_prior_median")), o.real("signal_std_prior_sd")};
        s.priors.noise_std = {std::log(o.real("noise_std_prior_median")), o.real("noise_std_prior_sd")};
        s.min_lengthscale = o.real("min_lengthscale");
        s.max_lengthscale = o.real("max_lengthscale");
        s.min_signal_std = o.real("min_signal_std");
        s.max_signal_std = o.real("max_signal_std");
        s.min_noise_std = o.real("min_noise_std");
        s.max_noise_std = o.real("max_noise_std");
        if (ctx.registry == nullptr) throw std::logic_error("gp: BuildContext without registry");
        std::shared_ptr<const Optimizer> optimizer = ctx.registry->create<Optimizer>(o.component("fit_optimizer"), ctx);
        auto gp = std::make_unique<GpSurrogate>(ctx.dim, s, std::move(optimizer));
        if (o.is_set("hyperparameters")) {
          const ConfigNode node = o.node("hyperparameters");
          try {
            gp->set_hyperparameters(parse_hyperparameters(node, ctx.dim));
          } catch (const ConfigError& e) {
            node.fail(e.what());
          }
        }
        return transforms::with_output_transform(std::move(gp),
                                                 transforms::parse_output_transform(o.str("output_transform")));
      }),
      {"surrogate:latent_variance"});
}

}  // namespace varbo::gp
