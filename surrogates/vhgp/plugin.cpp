// The `vhgp` plugin: registers the variational heteroscedastic GP surrogate (Kuindersma 2013, section 2.2).
// Its options are bound to VhgpConfig (varbo/option_set.hpp): the struct's member initializers are the declared
// defaults, so `--describe`, config.resolved.yaml and a default-constructed VhgpConfig agree.
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "given_parameters.hpp"
#include "gp_component.hpp"
#include "hyperparameter_map.hpp"
#include "transformed_surrogate.hpp"
#include "varbo/errors.hpp"
#include "varbo/option_set.hpp"
#include "varbo/plugin.hpp"
#include "vhgp_surrogate.hpp"

namespace {

using varbo::BoundOption;
using varbo::ConfigNode;
using varbo::LogNormalPrior;
using varbo::Options;
using varbo::vhgp::VhgpConfig;
using varbo::vhgp::VhgpHyperprior;

/// A prior option `[median, sd of log]` (log-normal, `median_is_positive`) or `[mean, sd]` (μ0) bound to a
/// LogNormalPrior of VhgpConfig::prior, which keeps (log median, sd): opt:: cannot bind that transform directly.
/// The default is written from VhgpConfig{} in the shortest form that reads back to the same double.
BoundOption<VhgpConfig> prior_option(std::string name, LogNormalPrior VhgpHyperprior::*field, bool median_is_positive,
                                     std::string doc) {
  const LogNormalPrior def = VhgpConfig{}.prior.*field;
  const double first = median_is_positive ? std::exp(def.mean) : def.mean;
  const std::string key = name;
  return {varbo::opt::reals(std::move(name), varbo::detail::reals_yaml({first, def.sd}), std::move(doc)),
          [key, field, median_is_positive](const Options& o, VhgpConfig& c) {
            const std::vector<double> v = o.reals(key);
            if (v.size() != 2 || !(v[1] > 0) || (median_is_positive && !(v[0] > 0)))
              o.node(key).fail(median_is_positive ? "expected [median, sd of its log] with both > 0"
                                                  : "expected [mean, sd] with sd > 0");
            c.prior.*field = LogNormalPrior{median_is_positive ? std::log(v[0]) : v[0], v[1]};
          }};
}

const varbo::OptionSet<VhgpConfig>& vhgp_options() {
  using varbo::Kind;
  using varbo::vhgp::HomoscedasticMember;
  using varbo::vhgp::NoiseModel;
  using varbo::vhgp::VhgpKernels;
  using C = VhgpConfig;
  namespace opt = varbo::opt;
  static const varbo::OptionSet<VhgpConfig> set{
      // The kernels are components (read in make_vhgp); their declared defaults are VhgpKernels{}'s.
      opt::component("kernel_f", Kind::Kernel, "matern52_ard",
                     "covariance of the cost GP f: any kernel component (se_ard, matern12_ard, matern32_ard, "
                     "matern52_ard, rational_quadratic, linear, constant, white, {type: sum|product, terms: [...]}); "
                     "Matern-5/2 as the gp's before its `kernel: auto`; the paper's se_ard; the authors' code SE + "
                     "constant: {type: sum, terms: [se_ard, constant]}; or `auto`, the gp's `kernel: auto`: the "
                     "constant-noise gp member chooses between Matern-5/2 ARD and SE-ARD at its fits with all "
                     "restarts (Matern unless SE-ARD's fit objective is 3 nats higher) and the noise process's f takes "
                     "its choice, so where no noise process is selected the vhgp is the default gp (not the default: "
                     "it loses on severe-noise Rosenbrock at d = 5 as the gp's auto does; docs/noisy.md, session "
                     "17); without a gp member (noise_model heteroscedastic, homoscedastic_member vhgp) auto is "
                     "Matern-5/2"),
      opt::component("kernel_g", Kind::Kernel, "se_ard",
                     "covariance of the log-noise GP g: any kernel component; the authors' code SE + white noise: "
                     "{type: sum, terms: [se_ard, white]}"),
      opt::real("jitter", opt::nested(&C::kernels, &VhgpKernels::jitter),
                "relative jitter: jitter*diag(K) added to each training covariance (GPML covSEisoj uses 1e-6, "
                "which floors the noise sd at 1e-3 sigma_f); 0 for none")
          .at_least(0)
          .at_most(1),
      opt::choice("noise_model", &C::noise_model,
                  {{"auto", NoiseModel::Auto},
                   {"heteroscedastic", NoiseModel::Heteroscedastic},
                   {"homoscedastic", NoiseModel::Homoscedastic}},
                  "auto: the heteroscedastic fit unless its bound beats the constant-noise member of the model "
                  "(a GP) by less than 1/2 p log N, p = the number of g's hyperparameters (its BIC penalty); "
                  "heteroscedastic: always the paper's model; homoscedastic: always constant noise"),
      opt::integer("restarts", &C::restarts, "optimizer starts per fit (warm start, GP initialization, random)")
          .at_least(1)
          .at_most(1000),
      opt::integer("restart_evaluations", &C::restart_evaluations,
                   "objective evaluations per start before only the best `finalists` starts continue to "
                   "convergence; 0: every start runs to convergence")
          .at_least(0),
      opt::integer("finalists", &C::finalists, "starts optimized to convergence after the first stage").at_least(1),
      opt::real("full_fit_growth", &C::full_fit_growth,
                "a full fit (GP initialization and all restarts) once N has grown by this factor since the last "
                "one; in between only the warm start is optimized (1: every fit is full)")
          .at_least(1),
      opt::integer("warm_evaluations", &C::warm_evaluations,
                   "objective evaluations of the warm start in a fit between full fits (it continues from the "
                   "previous optimum with one point more); 0: to convergence")
          .at_least(0),
      opt::boolean("warm_final_refit", &C::warm_final_refit,
                   "bo's final recommendation refit continues this model's fit schedule from its snapshot "
                   "(warm-only unless N has grown by full_fit_growth); false: a full fit of a fresh model"),
      opt::boolean("select_every_fit", &C::select_every_fit,
                   "noise_model auto: choose between the noise process and constant noise at every fit; false: "
                   "only at full fits, refitting only the chosen family in between"),
      opt::boolean("warm_lambda_only", &C::warm_lambda_only,
                   "a fit between full fits optimizes only log Lambda at the previous hyperparameters; false: all "
                   "parameters from the warm start (then warm_evaluations applies)"),
      opt::choice("homoscedastic_member", &C::homoscedastic_member,
                  {{"vhgp", HomoscedasticMember::Vhgp}, {"gp", HomoscedasticMember::Gp}},
                  "the constant-noise member of noise_model auto / homoscedastic: vhgp: fitted with this vhgp's f "
                  "priors; gp: the `gp` surrogate with its defaults and kernel_f (its priors, noise floor, "
                  "restarts, fit schedule and fit_optimizer), which then also predicts when it is selected; the "
                  "noise process keeps this vhgp's priors and the selection is unchanged (default gp: where no noise "
                  "process is found the vhgp is the gp; docs/noisy.md, branch vh14)"),
      opt::component("fit_optimizer", Kind::Optimizer, "ceres_lbfgs", "optimizer maximizing the bound"),
      opt::boolean("hyperpriors", opt::nested(&C::prior, &VhgpHyperprior::enabled),
                   "add independent log-normal hyperpriors to the bound (eq. 13)"),
      prior_option("prior_lengthscale_f", &VhgpHyperprior::lengthscale_f, true,
                   "[median, sd of log] of every lengthscale of kernel_f (unit cube)"),
      prior_option("prior_lengthscale_g", &VhgpHyperprior::lengthscale_g, true,
                   "[median, sd of log] of every lengthscale of kernel_g (unit cube)"),
      prior_option("prior_signal_std_f", &VhgpHyperprior::signal_f, true,
                   "[median, sd of log] of every amplitude of kernel_f (sigma_f, a constant term's std; "
                   "standardized costs)"),
      prior_option("prior_signal_std_g", &VhgpHyperprior::signal_g, true,
                   "[median, sd of log] of every amplitude of kernel_g (sigma_g)"),
      prior_option("prior_mu0", &VhgpHyperprior::mu0, false,
                   "[mean, sd] of mu0, the log noise variance (standardized): 2 log 0.01, a noise sd median of "
                   "0.01 std(y), as the gp's"),
      opt::boolean("standardize", &C::standardize, "standardize costs inside the model (predictions stay in cost units)"),
      opt::boolean("warm_start", &C::warm_start, "start one restart from the previous fit (new points: log Lambda = log 1/2)"),
      opt::boolean("lambda_warmup", &C::lambda_warmup,
                   "optimize log Lambda alone before each joint optimization (about twice the time)"),
      opt::boolean("fixed_hyperparameters", &C::fixed_hyperparameters,
                   "keep `hyperparameters` (or the defaults) fixed in every fit and optimize only log Lambda; "
                   "otherwise they are the start of one restart"),
      opt::node("hyperparameters", "",
                "initial hyperparameters in cost units (one start of the fit, or fixed with fixed_hyperparameters), "
                "by the kernels' names with _f or _g: {lengthscale_f: [..], signal_std_f, lengthscale_g: [..], "
                "signal_std_g, mu0} for ARD kernels, terms[i].<name>_f for composites"),
      opt::reals("log_lambda", "", "initial variational parameters log Lambda, one per data point"),
      opt::choice("output_transform", "none", varbo::transforms::output_transform_names(),
                  varbo::transforms::output_transform_description()),
  };
  return set;
}

/// The kernel component at `key`, built for a dimension through the registry (composites build their terms).
varbo::vhgp::KernelSpec kernel_spec(const Options& o, const std::string& key, const varbo::BuildContext& ctx) {
  const varbo::Registry* registry = ctx.registry;
  const varbo::ResolvedComponent kernel = o.component(key);
  const std::uint64_t seed = ctx.seed;
  return varbo::vhgp::KernelSpec([registry, kernel, seed](varbo::Index dim) {
    varbo::BuildContext c;
    c.registry = registry;
    c.dim = dim;
    c.seed = seed;
    return registry->create<varbo::Kernel>(kernel, c);
  });
}

/// `kernel_f: auto`: the candidates of the gp's `kernel: auto` (gp_component.hpp's kAutoCandidates), each with
/// the noise floor the `gp` component gives it when min_noise_std is not set (1e-7 for se_ard), so that the gp
/// member chooses exactly as a default `gp` does.
std::vector<varbo::gp::KernelCandidate> auto_f_candidates(const varbo::BuildContext& ctx) {
  const varbo::Registry* registry = ctx.registry;
  const std::uint64_t seed = ctx.seed;
  const varbo::gp::GpSettings defaults;
  const ConfigNode list = ConfigNode::parse(varbo::gp::kAutoCandidates, "<vhgp: kernel_f auto's candidates>");
  std::vector<varbo::gp::KernelCandidate> out;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const varbo::ResolvedComponent k = registry->resolve(varbo::Kind::Kernel, list.item(i));
    varbo::gp::KernelCandidate c;
    c.name = k.info ? k.info->name : "kernel " + std::to_string(i);
    c.make = [registry, k, seed](varbo::Index dim) {
      varbo::BuildContext b;
      b.registry = registry;
      b.dim = dim;
      b.seed = seed;
      return registry->create<varbo::Kernel>(k, b);
    };
    c.min_noise_std = varbo::gp::default_min_noise_std(c.name, defaults.min_noise_std, defaults.max_noise_std);
    out.push_back(std::move(c));
  }
  return out;
}

std::unique_ptr<varbo::Surrogate> make_vhgp(const Options& o, const varbo::BuildContext& ctx) {
  using namespace varbo::vhgp;
  if (ctx.registry == nullptr) throw varbo::ConfigError("vhgp: no registry to create the kernels and the fit optimizer");
  VhgpConfig c = vhgp_options().read(o);
  const varbo::ResolvedComponent kernel_f = o.component("kernel_f");
  if (kernel_f.info && kernel_f.info->name == varbo::gp::kAutoKernel)
    c.kernel_f_candidates = auto_f_candidates(ctx);  // (`auto` inside a composite is refused when built)
  else
    c.kernels.f = kernel_spec(o, "kernel_f", ctx);
  c.kernels.g = kernel_spec(o, "kernel_g", ctx);
  std::shared_ptr<const varbo::Optimizer> optimizer =
      ctx.registry->create<varbo::Optimizer>(o.component("fit_optimizer"), ctx);
  std::shared_ptr<const varbo::Optimizer> gp_optimizer;
  if (c.homoscedastic_member == HomoscedasticMember::Gp) {
    // As the `gp` component (gp_component.hpp): its declared fit_optimizer and its noise floor for kernel_f.
    gp_optimizer = ctx.registry->create<varbo::Optimizer>(std::string(varbo::gp::kDefaultFitOptimizer), ctx);
    const varbo::ResolvedComponent kf = o.component("kernel_f");
    const varbo::gp::GpSettings defaults;
    if (kf.info)
      c.gp_member_min_noise_std =
          varbo::gp::default_min_noise_std(kf.info->name, defaults.min_noise_std, defaults.max_noise_std);
  }
  auto model = std::make_unique<VhgpSurrogate>(ctx.dim, c, std::move(optimizer), std::move(gp_optimizer));
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
  registry.add(varbo::make_component<varbo::Surrogate>(
      "vhgp",
      "Variational heteroscedastic GP: cost GP f and log-noise GP g (each any kernel), marginal variational bound "
      "maximized jointly over log Lambda and hyperparameters with restarts (Kuindersma 2013, eq. 6-7, 13)",
      vhgp_options().specs(), varbo::Factory<varbo::Surrogate>(make_vhgp), {"surrogate:latent_variance"}));
}
