#pragma once
// Fitting one surrogate to a data set, as `varbo fit` does: shared by the CLI and the Python module (varbo.fit), so
// both give the same numbers.
#include <cstdint>
#include <memory>
#include <string>

#include "varbo/registry.hpp"

namespace varbo {

struct SurrogateFit {
  ResolvedComponent component;       ///< as built (restarts lowered for large N unless the YAML sets them)
  std::unique_ptr<Surrogate> model;
  FitReport report;
};

/// The surrogate a YAML document describes: a surrogate map ({type: gp, ...}), or a study file's `surrogate:` or
/// `algorithm.surrogate:` key.
ConfigNode surrogate_node(const ConfigNode& root);

/// Builds the surrogate of `node` for data.dim() coordinates (used as given: the model's coordinates) and fits its
/// hyperparameters (restarts seeded by `seed`), or with optimize = false only conditions it on the hyperparameters
/// the YAML gives. Past 500 points an exact fit gets 1 restart unless `restarts:` is set. A standard exception
/// inside the model becomes a NumericalError naming `data_name`; a failed optimization is not an exception
/// (report.ok = false).
SurrogateFit fit_surrogate(const Registry& registry, const ConfigNode& node, const Dataset& data, std::uint64_t seed,
                           bool optimize, const std::string& data_name);

}  // namespace varbo
