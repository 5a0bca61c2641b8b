// The `vhgp` plugin: registers the variational heteroscedastic GP surrogate (Kuindersma 2013, section 2.2).
#include <cmath>
#include <string>

#include "given_parameters.hpp"
#include "hyperparameter_map.hpp"
#include "kernel.hpp"
#include "transformed_surrogate.hpp"
#include "varbo/errors.hpp"
#include "varbo/plugin.hpp"
#include "vhgp_surrogate.hpp"

namespace {

using varbo::ConfigNode;
using varbo::Options;

varbo::LogNormalPrior prior_from(const Options& o, const std::string& name, bool median_is_positive) {
  const std::vector<double> v = o.reals(name);
  if (v.size() != 2 || !(v[1] > 0) || (median_is_positive && !(v[0] > 0)))
    o.node(name).fail(median_is_positive ? "expected [median, sd of its log] with both > 0"
                                         : "expected [mean, sd] with sd > 0");
  return varbo::LogNormalPrior{median_is_positive ? std::log(v[0]) : v[0], v[1]};
}

/// The VHGP bound is written for one stationary ARD kernel per process (vhgp_bound.cpp): any kernel component
/// resolves here, but only those four are accepted (composites: see README.md, "Kernels").
varbo::kernels::KernelType ard_kernel(const Options& o, const std::string& key) {
  const varbo::ResolvedComponent& k = o.component(key);
  try {
    return varbo::kernels::parse_kernel_type(k.info->name);
  } catch (const std::invalid_argument&) {
    o.node(key).fail("vhgp: kernel '" + k.info->name +
                     "' is not supported here; expected se_ard, matern12_ard, matern32_ard or matern52_ard");
  }
}

std::unique_ptr<varbo::Surrogate> make_vhgp(const Options& o, const varbo::BuildContext& ctx) {
  using namespace varbo::vhgp;
  VhgpConfig c;
  c.kernels.f = ard_kernel(o, "kernel_f");
  c.kernels.g = ard_kernel(o, "kernel_g");
  c.kernels.jitter = o.real("jitter");
  const std::string noise_model = o.str("noise_model");
  c.noise_model = noise_model == "heteroscedastic" ? NoiseModel::Heteroscedastic
                  : noise_model == "homoscedastic" ? NoiseModel::Homoscedastic
                                                   : NoiseModel::Auto;
  c.restarts = static_cast<int>(o.integer("restarts"));
  c.standardize = o.boolean("standardize");
  c.warm_start = o.boolean("warm_start");
  c.lambda_warmup = o.boolean("lambda_warmup");
  c.restart_evaluations = static_cast<int>(o.integer("restart_evaluations"));
  c.finalists = static_cast<int>(o.integer("finalists"));
  c.fixed_hyperparameters = o.boolean("fixed_hyperparameters");
  c.full_fit_growth = o.real("full_fit_growth");
  c.prior.enabled = o.boolean("hyperpriors");
  c.prior.lengthscale_f = prior_from(o, "prior_lengthscale_f", true);
  c.prior.lengthscale_g = prior_from(o, "prior_lengthscale_g", true);
  c.prior.signal_f = prior_from(o, "prior_signal_std_f", true);
  c.prior.signal_g = prior_from(o, "prior_signal_std_g", true);
  c.prior.mu0 = prior_from(o, "prior_mu0", false);
  if (ctx.registry == nullptr) throw varbo::ConfigError("vhgp: no registry to create the fit optimizer");
  std::shared_ptr<const varbo::Optimizer> optimizer =
      ctx.registry->create<varbo::Optimizer>(o.component("fit_optimizer"), ctx);
  auto model = std::make_unique<VhgpSurrogate>(ctx.dim, c, std::move(optimizer));
  // Every hyperparameter counts as missing until the YAML gives it (GivenParameters: conditioning without a fit
  // needs them all).
  std::vector<std::string> names;
  for (const auto& h : model->hyperparameters()) names.push_back(h.name);
  const std::vector<std::string> known = names;
  auto given = std::make_unique<GivenParameters>(std::move(model), std::move(names), o.node("hyperparameters"),
                                                 o.node("log_lambda"), std::nullopt);
  if (o.is_set("hyperparameters")) {
    const ConfigNode node = o.node("hyperparameters");
    const varbo::Hyperparameters values = varbo::kernels::parse_hyperparameter_map(node, known, {"mu0"});
    try {
      given->set_hyperparameters(values);
    } catch (const varbo::ConfigError& e) {
      node.fail(e.what());
    }
  }
  if (o.is_set("log_lambda")) {
    const std::vector<double> v = o.reals("log_lambda");
    given->set_state("log_lambda", Eigen::Map<const varbo::Vec>(v.data(), static_cast<varbo::Index>(v.size())));
  }
  return varbo::transforms::with_output_transform(
      std::move(given), varbo::transforms::parse_output_transform(o.str("output_transform")));
}

}  // namespace

VARBO_PLUGIN("vhgp", "0.1.0", "Variational heteroscedastic GP surrogate (Lazaro-Gredilla & Titsias 2011)") {
  using varbo::Kind;
  namespace opt = varbo::opt;
  registry.add(varbo::make_component<varbo::Surrogate>(
      "vhgp",
      "Variational heteroscedastic GP: cost GP f and log-noise GP g, marginal variational bound maximized jointly "
      "over log Lambda and hyperparameters with restarts (Kuindersma 2013, eq. 6-7, 13)",
      {
          opt::component("kernel_f", Kind::Kernel, "matern52_ard",
                         "covariance of the cost GP f: se_ard, matern12_ard, matern32_ard or matern52_ard (Matern-5/2 "
                         "as the gp's; se_ard is the paper's)"),
          opt::component("kernel_g", Kind::Kernel, "se_ard",
                         "covariance of the log-noise GP g: se_ard, matern12_ard, matern32_ard or matern52_ard"),
          opt::real("jitter", 1e-11, "relative jitter: jitter*sigma^2 added to each training covariance diagonal "
                                     "(GPML covSEisoj uses 1e-6, which floors the noise sd at 1e-3 sigma_f); 0 for none")
              .at_least(0)
              .at_most(1),
          opt::choice("noise_model", "auto", {"auto", "heteroscedastic", "homoscedastic"},
                      "auto: the heteroscedastic fit unless its bound beats the constant-noise member of the model "
                      "(a GP) by less than 1/2 (d+1) log N, the BIC penalty of g's hyperparameters; "
                      "heteroscedastic: always the paper's model; homoscedastic: always constant noise"),
          opt::integer("restarts", 8, "optimizer starts per fit (warm start, GP initialization, random)").at_least(1),
          opt::integer("restart_evaluations", 40,
                       "objective evaluations per start before only the best `finalists` starts continue to "
                       "convergence; 0: every start runs to convergence")
              .at_least(0),
          opt::integer("finalists", 2, "starts optimized to convergence after the first stage").at_least(1),
          opt::real("full_fit_growth", 1.25,
                    "a full fit (GP initialization and all restarts) once N has grown by this factor since the last "
                    "one; in between only the warm start is optimized (1: every fit is full)")
              .at_least(1),
          opt::component("fit_optimizer", Kind::Optimizer, "ceres_lbfgs", "optimizer maximizing the bound"),
          opt::boolean("hyperpriors", true, "add independent log-normal hyperpriors to the bound (eq. 13)"),
          opt::reals("prior_lengthscale_f", "[1.0, 1.6]", "[median, sd of log] of the f lengthscales (unit cube)"),
          opt::reals("prior_lengthscale_g", "[1.0, 1.6]", "[median, sd of log] of the g lengthscales (unit cube)"),
          opt::reals("prior_signal_std_f", "[1.0, 1.0]", "[median, sd of log] of sigma_f (standardized costs)"),
          opt::reals("prior_signal_std_g", "[1.0, 1.0]", "[median, sd of log] of sigma_g"),
          opt::reals("prior_mu0", "[-9.210340372, 6.0]",
                     "[mean, sd] of mu0, the log noise variance (standardized): noise sd median 0.01 std(y), as the gp's"),
          opt::boolean("standardize", true, "standardize costs inside the model (predictions stay in cost units)"),
          opt::boolean("warm_start", true, "start one restart from the previous fit (new points: log Lambda = log 1/2)"),
          opt::boolean("lambda_warmup", false, "optimize log Lambda alone before each joint optimization (about twice the time)"),
          opt::boolean("fixed_hyperparameters", false,
                       "keep `hyperparameters` (or the defaults) fixed in every fit and optimize only log Lambda; "
                       "otherwise they are the start of one restart"),
          opt::node("hyperparameters", "",
                    "initial hyperparameters in cost units (one start of the fit, or fixed with "
                    "fixed_hyperparameters): {lengthscale_f: [..], signal_std_f, lengthscale_g: [..], "
                    "signal_std_g, mu0}"),
          opt::reals("log_lambda", "", "initial variational parameters log Lambda, one per data point"),
          opt::choice("output_transform", "none", varbo::transforms::output_transform_names(),
                      varbo::transforms::output_transform_description()),
      },
      varbo::Factory<varbo::Surrogate>(make_vhgp), {"surrogate:latent_variance"}));
}
