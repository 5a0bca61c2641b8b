#include "gp_component.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "gp_surrogate.hpp"
#include "hyperparameter_map.hpp"
#include "transformed_surrogate.hpp"
#include "varbo/errors.hpp"
#include "varbo/option_set.hpp"
#include "varbo/numbers.hpp"

namespace varbo::gp {

namespace {

void check_range(const Options& o, const std::string& lo, const std::string& hi) {
  if (o.real(lo) < o.real(hi)) return;
  // Report at the key the user wrote: with only min_signal_std: 30 given, the culprit is not max's default 20.
  const std::string& at = o.given(hi) || !o.given(lo) ? hi : lo;
  o.node(at).fail(fmt::format("gp: expected {} < {}, got {} = {}{} and {} = {}{}", lo, hi, lo, o.real(lo),
                              o.given(lo) ? "" : " (the default)", hi, o.real(hi), o.given(hi) ? "" : " (the default)"));
}

// The hyperpriors are stored as log-normal priors (log-median, sd of the log) in GpSettings::priors, two
// levels down and in log space, which opt:: cannot bind directly: these two adapters bind them by hand, still
// with the defaults of GpSettings{}. The median is declared at 15 significant digits so that exp(log(0.01))
// shows (and reads back) as 0.01.
BoundOption<GpSettings> prior_median(std::string name, LogNormalPrior HyperPriors::*prior, std::string doc) {
  const std::string key = name;
  const double median = strtod_c(fmt::format("{:.15g}", std::exp((GpSettings{}.priors.*prior).mean)).c_str(), nullptr);
  return {opt::real(std::move(name), median, std::move(doc)).above(0),
          [key, prior](const Options& o, GpSettings& s) { (s.priors.*prior).mean = std::log(o.real(key)); }};
}
BoundOption<GpSettings> prior_sd(std::string name, LogNormalPrior HyperPriors::*prior, std::string doc) {
  const std::string key = name;
  return {opt::real(std::move(name), (GpSettings{}.priors.*prior).sd, std::move(doc)).above(0),
          [key, prior](const Options& o, GpSettings& s) { (s.priors.*prior).sd = o.real(key); }};
}

/// `kernel_candidates`: ≥ 2 kernel components whose hyperparameters have the same names (the choice is then
/// between equally many parameters, and the values of one warm-start the other), each with its noise floor.
std::vector<KernelCandidate> read_candidates(const ConfigNode& list, const Options& o,
                                             const std::function<KernelMaker(const ResolvedComponent&)>& maker,
                                             const GpSettings& s, const Registry& registry, Index dim) {
  // `kernel` is not refused beside the list: a study stored before `kernel: auto` lists `kernel: matern52_ard`
  // (the default then) in its resolved configuration beside a given list.
  if (!list.is_sequence() || list.size() < 2)
    list.fail("gp: expected a list of at least two kernels, e.g. [matern52_ard, se_ard]");
  std::vector<KernelCandidate> out;
  std::vector<std::string> first_names, seen;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const ConfigNode item = list.item(i);
    const ResolvedComponent k = registry.resolve(Kind::Kernel, item);
    // The same kernel twice was fitted twice, for nothing (red team, session 26).
    YAML::Emitter em;
    em << YAML::Flow << k.resolved();
    const std::string text = em.c_str();
    if (std::find(seen.begin(), seen.end(), text) != seen.end())
      item.fail("gp: kernel_candidates lists " + text + " twice; each candidate once");
    seen.push_back(text);
    KernelCandidate c;
    c.name = k.info ? k.info->name : "kernel " + std::to_string(i);
    c.make = maker(k);
    c.min_noise_std = o.is_set("min_noise_std") ? s.min_noise_std
                                                : default_min_noise_std(c.name, s.min_noise_std, s.max_noise_std);
    std::vector<std::string> names;
    const std::unique_ptr<Kernel> built = c.make(std::max<Index>(dim, 1));
    for (const KernelParameter& p : built->parameters()) names.push_back(p.name);
    if (i == 0) first_names = names;
    if (names != first_names)
      item.fail("gp: kernel_candidates must have the same hyperparameters; " + c.name + " has [" + join(names) +
                "], " + out.front().name + " has [" + join(first_names) + "]");
    out.push_back(std::move(c));
  }
  return out;
}

}  // namespace

const OptionSet<GpSettings>& gp_options() {
  using S = GpSettings;
  static const OptionSet<GpSettings> set{
      opt::component("kernel", Kind::Kernel, kAutoKernel,
                     "covariance function: `auto` (the kernel chosen by the data among kernel_candidates, by default "
                     "[matern52_ard, se_ard]: Matérn-5/2 ARD unless SE-ARD fits kernel_choice_margin nats better) or a "
                     "kernel component (se_ard, matern12_ard, matern32_ard, matern52_ard, rational_quadratic, linear, "
                     "constant, white, {type: sum|product, terms: [...]}); its lengthscales and amplitudes take the "
                     "priors and bounds below"),
      opt::node("kernel_candidates", "",
                "the kernels `kernel: auto` chooses among (when given, also with any other `kernel`, which is then "
                "ignored; when not given: [matern52_ard, se_ard]): ≥ 2 kernels with the same hyperparameter names; "
                "each fit with all restarts fits every candidate (same restarts and random streams) and keeps "
                "the first one whose fit objective (log marginal likelihood + log hyperprior: with the same "
                "hyperparameters no complexity penalty is needed) is within kernel_choice_margin of the best; "
                "warm-only refits keep it. Each candidate has its own default noise floor (min_noise_std). The "
                "choice is saved with the model's state and shown in model.yaml's note and the log "
                "(docs/defaults.md, \"Kernel chosen by the data\")"),
      opt::real("kernel_choice_margin", &S::kernel_choice_margin,
                "with kernel auto or kernel_candidates: the first candidate whose fit objective is within this margin "
                "(in nats) of the best one is kept, so that the list is an order of preference (0: the best; 3, a "
                "Bayes factor of e^3 ≈ 20: a later candidate must fit clearly better)")
          .at_least(0),
      opt::integer("restarts", &S::restarts, "optimizer runs per fit (the first warm-started from the previous fit)")
          .at_least(1)
          .at_most(1000),
      opt::real("full_fit_growth", &S::full_fit_growth,
                "all restarts once N has grown by this factor since the last such fit (and always up to N = 20); "
                "in between only the warm start (1: all restarts at every fit)")
          .at_least(1),
      opt::component("fit_optimizer", Kind::Optimizer, kDefaultFitOptimizer,
                     "optimizer of the log posterior over log-hyperparameters"),
      opt::choice("prior_mean", &S::prior_mean, {{"data_mean", S::PriorMean::DataMean}, {"max", S::PriorMean::Max}},
                  "constant prior mean: the mean of the costs, or the largest cost (pessimistic: unexplored "
                  "regions look no better than the worst trial; De Ath et al. 2020)"),
      opt::boolean("priors", opt::nested(&S::priors, &HyperPriors::enabled),
                   "add the log-normal hyperpriors to the objective (false: plain ML-II)"),
      prior_median("lengthscale_prior_median", &HyperPriors::lengthscale, "median of the lengthscale prior (unit cube)"),
      prior_sd("lengthscale_prior_sd", &HyperPriors::lengthscale, "sd of log lengthscale"),
      prior_median("signal_std_prior_median", &HyperPriors::signal_std,
                   "median of the signal std prior, relative to std(y)"),
      prior_sd("signal_std_prior_sd", &HyperPriors::signal_std, "sd of log signal std"),
      prior_median("noise_std_prior_median", &HyperPriors::noise_std, "median of the noise std prior, relative to std(y)"),
      prior_sd("noise_std_prior_sd", &HyperPriors::noise_std,
               "sd of log noise std (wide: the data decide between noise-free and noisy)"),
      opt::real("min_lengthscale", &S::min_lengthscale, "lower bound of each lengthscale (unit cube)").above(0),
      opt::real("max_lengthscale", &S::max_lengthscale, "upper bound of each lengthscale (unit cube)").above(0),
      opt::real("min_signal_std", &S::min_signal_std, "lower bound of the signal std, relative to std(y)").above(0),
      opt::real("max_signal_std", &S::max_signal_std, "upper bound of the signal std, relative to std(y)").above(0),
      // min_noise_std and noise_test_level have no declared default: unset, they are decided by the kernel
      // (default_min_noise_std; 1e-3 with se_ard, off otherwise) and stay out of the resolved configuration, so a
      // study reopens with the floor and the test of the run that made it (one stored before session 17 lists
      // `noise_test_level: 0`).
      opt::real("min_noise_std", &S::min_noise_std,
                "lower bound of the noise std, relative to std(y); when not given, by kernel: 1e-7 with se_ard (also "
                "as a kernel_candidates entry), 1e-6 otherwise")
          .above(0)
          .when_given(),
      opt::real("max_noise_std", &S::max_noise_std, "upper bound of the noise std, relative to std(y)").above(0),
      opt::real("noise_test_level", &S::noise_test_level,
                "> 0: before each fit the noise std is bounded by a one-sided test at this level on the cost "
                "differences of the nearest pairs of points (a deterministic cost's near pairs, above all an exact "
                "replicate, rule out noise that its structure would otherwise be fitted as; `bo` then repeats a "
                "design point unless its replicate_design is false); 0: off. When not given, by kernel: 1e-3 with "
                "se_ard, off otherwise (auto, Matérn, composites)")
          .at_least(0)
          .below(1)
          .when_given(),
      opt::boolean("noise_test_tight", &S::noise_test_tight,
                   "with noise_test_level: when the data show no noise at all (bound ≤ 1e-5·std(y), e.g. exact "
                   "replicates), fit under the tight noise prior LogNormal(1e-6, 1.5) instead of the cap"),
      opt::choice("output_transform", "none", transforms::output_transform_names(),
                  transforms::output_transform_description()),
      opt::node("hyperparameters", "",
                "initial (or, with `varbo fit --no-optimize`, fixed) values in natural units, by the kernel's "
                "names (composites: terms[i].<name>): lengthscale (number or list), lengthscale[i], signal_std, "
                "noise_std (cost units), mean (fixes the "
                "constant mean; otherwise it is the data mean)"),
  };
  return set;
}

ComponentInfo auto_kernel_component() {
  return make_component<Kernel>(
      kAutoKernel,
      "gp's kernel and vhgp's kernel_f only: the kernel chosen by the data at each fit with all restarts, among the "
      "gp's kernel_candidates (default [matern52_ard, se_ard]; Matérn-5/2 ARD unless SE-ARD's fit objective is "
      "kernel_choice_margin, default 3, nats higher; the vhgp's gp member chooses for its f). The gp's default kernel",
      {},
      Factory<Kernel>([](const Options&, const BuildContext&) -> std::unique_ptr<Kernel> {
        throw std::invalid_argument(
            "'auto' is the gp's choice between kernels, not a kernel itself; give a kernel such as matern52_ard or "
            "se_ard here");
      }),
      {"kernel"});
}

double default_min_noise_std(const std::string& kernel, double configured, double max_noise_std) {
  return kernel == "se_ard" ? std::min(kSeArdMinNoiseStd, max_noise_std) : configured;
}

ComponentInfo gp_component() {
  return make_component<Surrogate>(
      "gp",
      "Gaussian process with constant mean, standardized costs, any `kernel` (default `auto`: Matern-5/2 ARD or "
      "SE-ARD, chosen by the data) and Gaussian noise. Hyperparameters maximize the log marginal likelihood plus "
      "independent log-normal hyperpriors (Kuindersma 2013, eq. 13), with parallel random restarts of "
      "`fit_optimizer`.",
      gp_options().specs(),
      Factory<Surrogate>([](const Options& o, const BuildContext& ctx) -> std::unique_ptr<Surrogate> {
        check_range(o, "min_lengthscale", "max_lengthscale");
        check_range(o, "min_signal_std", "max_signal_std");
        if (o.is_set("min_noise_std")) check_range(o, "min_noise_std", "max_noise_std");
        GpSettings s = gp_options().read(o);
        if (ctx.registry == nullptr) throw std::logic_error("gp: BuildContext without registry");
        // Built once here so that a bad kernel is reported at construction; later dimensions build their own.
        const Registry* registry = ctx.registry;
        const ResolvedComponent kernel = o.component("kernel");
        const bool choose_kernel =
            o.is_set("kernel_candidates") || (kernel.info && kernel.info->name == kAutoKernel);
        // The noise floor by kernel when not given: 1e-7·std(y) for se_ard, 1e-6 for the others. On noise-free
        // costs the fitted noise sits on the floor, and SE-ARD, whose prior cannot follow the data as closely as
        // Matérn's, then explains misfits of up to half the floor as noise (Hartmann-3: residuals 5e-7·std(y)
        // against Matérn's 9e-8), which caps the precision of its refinement; docs/defaults.md, "Why SE-ARD is
        // weaker".
        if (!o.is_set("min_noise_std") && kernel.info && !choose_kernel)
          s.min_noise_std = default_min_noise_std(kernel.info->name, s.min_noise_std, s.max_noise_std);
        // SE-ARD tests its data for noise unless told otherwise: with an exact replicate in each design (bo's
        // replicate_design follows tests_noise_on_replicates) a deterministic cost is fitted as one, which is what
        // keeps SE-ARD out of Ackley's ripples (docs/defaults.md, "Session se15", "Session 17").
        if (!o.is_set("noise_test_level") && kernel.info && !choose_kernel && kernel.info->name == "se_ard")
          s.noise_test_level = kSeArdNoiseTestLevel;
        // Without a given floor the general one (1e-6) may exceed a small max_noise_std.
        if (!(s.min_noise_std < s.max_noise_std))
          o.node("max_noise_std").fail("gp: expected max_noise_std > the noise floor " + std::to_string(s.min_noise_std) +
                                       " (min_noise_std when not given)");
        const std::uint64_t seed = ctx.seed;
        const auto maker = [registry, seed](const ResolvedComponent& k) -> KernelMaker {
          return [registry, k, seed](Index dim) {
            BuildContext c;  // a kernel needs its dimension (and the registry, for composites' terms)
            c.registry = registry;
            c.dim = dim;
            c.seed = seed;
            return registry->create<Kernel>(k, c);
          };
        };
        if (choose_kernel) {  // the first candidate until a fit chooses
          const ConfigNode list = o.is_set("kernel_candidates")
                                      ? o.node("kernel_candidates")
                                      : ConfigNode::parse(kAutoCandidates, "<gp: kernel auto's candidates>");
          s.kernel_candidates = read_candidates(list, o, maker, s, *registry, ctx.dim);
          s.kernel = s.kernel_candidates.front().make;
        } else {
          s.kernel = maker(kernel);
        }
        if (ctx.dim > 0) s.kernel(ctx.dim);
        std::shared_ptr<const Optimizer> optimizer = ctx.registry->create<Optimizer>(o.component("fit_optimizer"), ctx);
        auto gp = std::make_unique<GpSurrogate>(ctx.dim, s, std::move(optimizer));
        if (o.is_set("hyperparameters")) {
          const ConfigNode node = o.node("hyperparameters");
          std::vector<std::string> names;
          for (const auto& h : gp->hyperparameters()) names.push_back(h.name);
          // Outside the try: a parse error already names its own key and position.
          const Hyperparameters values = kernels::parse_hyperparameter_map(node, names, {"mean"});
          try {
            gp->set_hyperparameters(values);
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
