// libvarbo_augmented_ei.so: augmented expected improvement (Huang et al. 2006) for noisy costs.
#include "augmented_ei.hpp"
#include "varbo/plugin.hpp"

VARBO_PLUGIN("augmented_ei", "0.1.0", "Augmented expected improvement for noisy, also heteroscedastic, costs") {
  using varbo::Acquisition;
  using varbo::BuildContext;
  using varbo::Options;
  namespace opt = varbo::opt;
  registry.add(varbo::make_component<Acquisition>(
      "aei",
      "augmented expected improvement (Huang et al. 2006): EI of the latent cost over the evaluated point "
      "minimizing μ + c·s, times 1 − σ_ε(θ)/sqrt(s²(θ) + σ_ε²(θ)) with the model's noise at θ",
      {opt::real("c", 1.0, "the incumbent minimizes μ + c·s over the evaluated points (s: latent std; Huang's c = 1)")
           .at_least(0),
       opt::boolean("noise_factor", true,
                    "multiply by Huang's factor 1 − σ_ε/sqrt(s² + σ_ε²) (false: EI of the latent cost alone)")},
      varbo::Factory<Acquisition>([](const Options& o, const BuildContext&) {
        return std::make_unique<varbo::acq::AugmentedExpectedImprovement>(o.real("c"), o.boolean("noise_factor"));
      }),
      {"acquisition:gradient"}));
}
