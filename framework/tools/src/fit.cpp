#include "varbo/fit.hpp"

#include <fmt/format.h>

#include <cmath>

#include "varbo/errors.hpp"
#include "varbo/loader.hpp"
#include "varbo/log.hpp"
#include "varbo/text.hpp"

namespace varbo {

namespace {

/// Each restart of an exact GP fit costs O(N³) per likelihood evaluation: past kManyPoints points, unless the
/// YAML sets `restarts`, one restart per fit (docs/studies.md, "varbo fit").
constexpr Index kManyPoints = 500;

ResolvedComponent with_fewer_restarts(const Registry& registry, ResolvedComponent rc, Index n) {
  if (n <= kManyPoints || rc.options.given("restarts")) return rc;
  bool declares = false;
  for (const auto& o : rc.info->options) declares = declares || o.name == "restarts";
  if (!declares || rc.options.integer("restarts") <= 1) return rc;
  YAML::Node m = YAML::Clone(rc.resolved());
  m["restarts"] = 1;
  YAML::Emitter em;
  em << m;
  log_info("varbo fit: {} points (> {}) and no `restarts:` given: 1 restart instead of {} (set restarts to override)",
           n, kManyPoints, rc.options.integer("restarts"));
  return registry.resolve(Kind::Surrogate, ConfigNode::parse(em.c_str(), "<varbo fit: restarts for large N>"));
}

}  // namespace

ConfigNode surrogate_node(const ConfigNode& root) {
  ConfigNode node = root;
  if (root.is_map() && root.has("surrogate")) node = root.child("surrogate");
  if (root.is_map() && root.has("algorithm") && root.child("algorithm").is_map() &&
      root.child("algorithm").has("surrogate"))
    node = root.child("algorithm").child("surrogate");
  return node;
}

SurrogateFit fit_surrogate(const Registry& registry, const ConfigNode& node, const Dataset& data, std::uint64_t seed,
                           bool optimize, const std::string& data_name) {
  SurrogateFit out;
  out.component = registry.resolve(Kind::Surrogate, node);
  if (optimize) out.component = with_fewer_restarts(registry, std::move(out.component), data.size());
  BuildContext ctx;
  ctx.dim = data.dim();
  ctx.seed = seed;
  out.model = registry.create<Surrogate>(out.component, ctx);
  if (optimize) {
    // θ is used as given, but the surrogates' lengthscale bounds and hyperpriors are stated for the unit cube
    // (lengthscales 0.01–50, prior median 0.5): raw gains or frequencies spanning 1000 were fitted as noise with
    // ok: true and no word (red team, session 25).
    std::string far;
    for (Index j = 0; j < data.dim() && data.size() > 1; ++j) {
      const double lo = data.X.col(j).minCoeff(), hi = data.X.col(j).maxCoeff(), span = hi - lo;
      if (std::isfinite(span) && (span > 50 || (span > 0 && span < 1e-2)))
        far += fmt::format("{}column {} spans {:.3g} ({:.4g} … {:.4g})", far.empty() ? "" : ", ", j + 1, span, lo, hi);
    }
    if (!far.empty())
      log_warn("{}: θ {}: the surrogate's lengthscale bounds and priors are for coordinates in [0, 1] (lengthscales "
               "0.01–50), so the fit may take the signal for noise or a constant; rescale each θ column to [0, 1] "
               "first, e.g. (θ − lower) / (upper − lower)",
               data_name, far);
  }
  Rng rng(seed);
  try {
    out.report = optimize ? out.model->fit(data, rng) : out.model->condition(data);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    // A third-party surrogate's own exception is its plugin's fault, not the data's: the scaling advice sent its
    // author to the CSV (audit, session 48; `varbo run` names the plugin the same way, plugin_code.hpp).
    if (!is_builtin(*out.component.info))
      throw PluginCodeError(fmt::format("{}: surrogate '{}' ({}) threw while {}: {} — an exception from plugin "
                                        "code, not a varbo error",
                                        data_name, out.component.info->full_name(), out.component.info->library,
                                        optimize ? "fitting" : "conditioning", safe_text(e.what(), 2000)));
    throw NumericalError(fmt::format("{}: the {} fit failed on this data: {} (are θ and y scaled to moderate "
                                     "magnitudes?)",
                                     data_name, out.component.info->name, e.what()));
  }
  return out;
}

}  // namespace varbo
