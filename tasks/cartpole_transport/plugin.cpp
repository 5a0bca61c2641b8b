// libvarbo_cartpole_transport: a gantry crane moving a swinging load (issue 5, item 3).
#include <fmt/format.h>

#include <cmath>

#include "transport_task.hpp"
#include "varbo/option_set.hpp"
#include "varbo/plugin.hpp"
#include "varbo/numbers.hpp"

namespace {
using namespace varbo;

/// `weights: {tracking: w, sway: w, energy: w}`; a component not listed has weight 1 (the convention
/// `varbo rescore` uses for every task with a `weights:` option).
std::map<std::string, double> parse_weights(const ConfigNode& node) {
  const std::vector<std::string> names{"tracking", "sway", "energy"};
  std::map<std::string, double> w{{"tracking", 1.0}, {"sway", 1.0}, {"energy", 1.0}};
  if (!node.is_map()) node.fail("expected a map of component names to weights, e.g. {tracking: 1, energy: 0.01}");
  for (const auto& key : node.keys()) {
    if (!w.count(key)) node.child(key).fail(fmt::format("unknown cost component '{}' (expected tracking, sway or energy)", key));
    const ConfigNode v = node.child(key);
    const double x = v.is_scalar() ? parse_decimal(v.scalar()).value_or(NAN) : NAN;
    if (!std::isfinite(x) || x < 0) v.fail("expected a finite weight >= 0");
    w[key] = x;
  }
  return w;
}

using transport::TransportSettings;
// `weights` stays a map option read by hand (its default YAML is the one place the default weights are shown).
const OptionSet<TransportSettings>& transport_options() {
  static const OptionSet<TransportSettings> set{
      opt::node("weights", "{tracking: 0.25, sway: 2.0, energy: 0.002}",
                "weight of each cost component (unlisted components: 1); the cost is their weighted sum"),
      opt::real("distance", &TransportSettings::distance, "transport distance D, m").above(0),
      opt::real("horizon", &TransportSettings::horizon, "episode length T, s (at most 1e6 steps of dt)").above(0),
      opt::real("dt", &TransportSettings::dt, "fixed RK4 step and disturbance hold, s").above(0).at_most(0.05),
      opt::real("load_mass", opt::nested(&TransportSettings::gantry, &transport::GantryParams::load_mass), "mean load mass m, kg")
          .above(0),
      opt::real("load_mass_std", &TransportSettings::load_mass_std, "per-episode std of the load mass, kg").at_least(0),
      opt::real("rod_length", opt::nested(&TransportSettings::gantry, &transport::GantryParams::rod_length), "mean rod length l, m")
          .above(0),
      opt::real("rod_length_std", &TransportSettings::rod_length_std, "per-episode std of the rod length, m")
          .at_least(0),
      opt::real("force_noise_std", &TransportSettings::force_noise_std,
                "std of the force disturbance held over each step, N")
          .at_least(0),
      opt::real("initial_swing_std", &TransportSettings::initial_swing_std, "std of the load's initial angle, rad")
          .at_least(0),
      opt::real("cart_mass", opt::nested(&TransportSettings::gantry, &transport::GantryParams::cart_mass), "cart mass M, kg")
          .above(0),
      opt::real("force_limit", opt::nested(&TransportSettings::gantry, &transport::GantryParams::force_limit),
                "servo force limit, N")
          .above(0)};
  return set;
}
}  // namespace

VARBO_PLUGIN("cartpole_transport", "0.1.0", "Gantry crane transporting a swinging load; tracking/sway/energy costs") {
  registry.add(make_component<Task>(
      "cartpole_transport",
      "cart with a load on a rod, PD servo tracking a cubic reference through 3 waypoints with 4 segment "
      "durations (7 parameters); random load mass and rod length, force disturbances; cost = "
      "w_tracking*int(x_load-D)^2 + w_sway*int(phi^2) + w_energy*int(F^2) over T",
      transport_options().specs(),
      Factory<Task>([](const Options& o, const BuildContext&) {
        transport::TransportSettings s = transport_options().read(o);
        // horizon: 1e300 (or dt: 1e-300) overflowed the step count to none: every θ cost 0, "perfect" (red team,
        // session 29). A million RK4 steps is already hours of simulation per trial.
        if (!(s.horizon / s.dt <= 1e6))
          o.node(o.given("horizon") ? "horizon" : "dt")
              .fail(fmt::format("horizon/dt = {:g} steps per episode; at most 1e6", s.horizon / s.dt));
        s.weights = parse_weights(o.node("weights"));
        return std::make_unique<transport::TransportTask>(s);
      })));
}
