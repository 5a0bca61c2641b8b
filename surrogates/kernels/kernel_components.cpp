#include "kernel_components.hpp"

#include "kernel_library.hpp"

namespace varbo::kernels {

namespace {

Index dimension(const BuildContext& ctx, const char* name) {
  if (ctx.dim < 1) throw std::invalid_argument(std::string(name) + ": the problem dimension is not known");
  return ctx.dim;
}

ComponentInfo simple(const char* name, const char* description, std::unique_ptr<Kernel> (*make)(Index)) {
  return make_component<Kernel>(name, description, {},
                                Factory<Kernel>([name, make](const Options&, const BuildContext& ctx) {
                                  return make(dimension(ctx, name));
                                }),
                                {"kernel"});
}

ComponentInfo stationary(const char* name, const char* description, KernelType type) {
  return make_component<Kernel>(name, description, {},
                                Factory<Kernel>([name, type](const Options&, const BuildContext& ctx) {
                                  return make_stationary_ard(type, dimension(ctx, name));
                                }),
                                {"kernel"});
}

/// `terms:` a non-empty list of kernel components (names or maps), each resolved and built like any component,
/// so a wrong entry is reported at its own file:line:col.
ComponentInfo composite(const char* name, const char* description,
                        std::unique_ptr<Kernel> (*make)(std::vector<std::unique_ptr<Kernel>>)) {
  return make_component<Kernel>(
      name, description,
      {opt::node("terms", "", "list of kernels, e.g. [se_ard, {type: constant}]").must()},
      Factory<Kernel>([make](const Options& o, const BuildContext& ctx) {
        const ConfigNode terms = o.node("terms");
        if (!terms.is_sequence() || terms.size() == 0)
          terms.fail("expected a non-empty list of kernels, e.g. [se_ard, {type: constant}]");
        if (ctx.registry == nullptr) throw std::logic_error("composite kernel: BuildContext without registry");
        std::vector<std::unique_ptr<Kernel>> built;
        for (std::size_t i = 0; i < terms.size(); ++i)
          built.push_back(ctx.registry->create<Kernel>(ctx.registry->resolve(Kind::Kernel, terms.item(i)), ctx));
        return make(std::move(built));
      }),
      {"kernel"});
}

}  // namespace

std::vector<ComponentInfo> kernel_components() {
  return {
      stationary("se_ard", "squared exponential with one lengthscale per dimension: s^2 exp(-r^2/2) (R&W eq. 4.9); "
                           "hyperparameters lengthscale[i], signal_std",
                 KernelType::SquaredExponential),
      stationary("matern12_ard", "Matern nu = 1/2 (exponential) ARD: s^2 exp(-r); lengthscale[i], signal_std",
                 KernelType::Matern12),
      stationary("matern32_ard", "Matern nu = 3/2 ARD: s^2 (1 + sqrt3 r) exp(-sqrt3 r); lengthscale[i], signal_std",
                 KernelType::Matern32),
      stationary("matern52_ard",
                 "Matern nu = 5/2 ARD: s^2 (1 + sqrt5 r + 5r^2/3) exp(-sqrt5 r) (R&W eq. 4.17); lengthscale[i], "
                 "signal_std",
                 KernelType::Matern52),
      simple("rational_quadratic",
             "rational quadratic ARD: s^2 (1 + r^2/(2 alpha))^-alpha (R&W eq. 4.19), SE as alpha -> inf; "
             "lengthscale[i], signal_std, alpha",
             make_rational_quadratic),
      simple("linear", "dot product s^2 x.x' (Bayesian linear regression through the origin); signal_std", make_linear),
      simple("constant", "constant s^2 (a random offset); signal_std", make_constant),
      simple("white", "white noise s^2 on the training points and on a point's own variance, 0 between points "
                      "(GPML covNoise); noise_std",
             make_white),
      composite("sum", "sum of the kernels in `terms`; hyperparameters terms[i].<name>", make_sum),
      composite("product",
                "elementwise product of the kernels in `terms`; hyperparameters terms[i].<name> (only the first "
                "term's signal_std carries the scale of the costs)",
                make_product),
  };
}

}  // namespace varbo::kernels
