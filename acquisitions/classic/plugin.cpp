// libvarbo_acquisitions.so: EI, PI, CB and ERI (Kuindersma 2013, section 3).
#include <fmt/format.h>

#include "classic_acquisitions.hpp"
#include "varbo/log.hpp"
#include "varbo/plugin.hpp"

namespace {
varbo::OptionSpec xi_option(double def) {
  return varbo::opt::real("xi", def,
                          "exploration ξ in units of σ_f = sqrt(signal variance): improvement is counted below "
                          "μ_best − ξ·σ_f, so a larger ξ explores more")
      .at_least(0);
}
varbo::OptionSpec gh_option() {
  return varbo::opt::integer("gh_nodes", 45,
                             "Gauss–Hermite nodes for the integral over the log noise (eq. 9); unused when the "
                             "model is homoscedastic (closed form)")
      .at_least(1)
      .at_most(200);
}
}  // namespace

VARBO_PLUGIN("acquisitions", "0.1.0", "Expected improvement, probability of improvement, confidence bound and "
                                      "expected risk improvement, for GP and heteroscedastic models") {
  using varbo::Acquisition;
  using varbo::BuildContext;
  using varbo::Options;
  namespace opt = varbo::opt;
  const std::vector<std::string> gradient{"acquisition:gradient"};

  registry.add(varbo::make_component<Acquisition>(
      "ei", "expected improvement over the lowest posterior mean at the data (Kuindersma 2013, eq. 9)",
      // ξ = 0 by default: ξ is scaled by σ_f, and a fitted σ_f can be many times the spread of the data (long
      // lengthscales on smooth costs), which turned ξ = 0.01 into pure exploration on Branin (bench/e2e).
      {xi_option(0.0), gh_option()},
      varbo::Factory<Acquisition>([](const Options& o, const BuildContext&) {
        return std::make_unique<varbo::acq::ExpectedImprovement>(o.real("xi"), static_cast<int>(o.integer("gh_nodes")));
      }),
      gradient));

  registry.add(varbo::make_component<Acquisition>(
      "pi", "probability of improving on the lowest posterior mean at the data by at least ξ·σ_f",
      {varbo::opt::real("xi", 0.01,
                        "required improvement ξ in units of σ_f: PI = P(y < μ_best − ξ·σ_f) (Kushner's convention)")
           .at_least(0),
       gh_option()},
      varbo::Factory<Acquisition>([](const Options& o, const BuildContext&) {
        return std::make_unique<varbo::acq::ProbabilityOfImprovement>(o.real("xi"),
                                                                      static_cast<int>(o.integer("gh_nodes")));
      }),
      gradient));

  registry.add(varbo::make_component<Acquisition>(
      "cb", "confidence bound: maximizes −(E[y] + κ·s), κ > 0 risk-averse (Kuindersma 2013, eq. 10)",
      {opt::real("kappa", -2.0,
                 "risk factor κ: > 0 risk-averse, < 0 risk-seeking/optimistic; the default −2 is the exploring "
                 "lower confidence bound of standard BO (ignored when randomize is true)"),
       opt::boolean("randomize", false, "draw κ ~ N(0, 1) every iteration (randomized CB selection)")},
      varbo::Factory<Acquisition>([](const Options& o, const BuildContext&) {
        // An option that cannot act is accepted with a warning (README): `{randomize: true, kappa: 3}` ran without a
        // word with κ drawn anew every trial (red team, session 30).
        if (o.given("kappa") && o.boolean("randomize"))
          varbo::log_warn_once(fmt::format("{}: cb's kappa {} is not used: randomize: true draws κ ~ N(0, 1) every "
                                           "trial",
                                           o.node("kappa").where(), o.real("kappa")));
        return std::make_unique<varbo::acq::ConfidenceBound>(o.real("kappa"), o.boolean("randomize"));
      }),
      gradient));

  registry.add(varbo::make_component<Acquisition>(
      "eri", "expected risk improvement over the evaluated point minimizing E + κ·s (Kuindersma 2013, eq. 12)",
      {opt::real("kappa", 1.0, "risk factor κ; ERI = EI at κ = 0"), xi_option(0.0), gh_option()},
      varbo::Factory<Acquisition>([](const Options& o, const BuildContext&) {
        return std::make_unique<varbo::acq::ExpectedRiskImprovement>(o.real("kappa"), o.real("xi"),
                                                                     static_cast<int>(o.integer("gh_nodes")));
      }),
      gradient));
}
