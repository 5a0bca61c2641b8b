// The RunContinuation extension (varbo/continuation.hpp) as the offline tools see it: found on rssgd through
// the registry (across the plugin boundary), absent elsewhere; the local model for a run of another algorithm
// equals rssgd's own defaults (ε = 3.5σ at the declared default σ, the declared min_local_points), so the two
// paths of `varbo rescore` agree; the continued algorithm block.
#include <yaml-cpp/yaml.h>

#include <string>

#include "varbo/continuation.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {
class OtherExtension final : public ComponentExtension {};

double declared_default(const ComponentInfo& info, const std::string& name) {
  for (const OptionSpec& o : info.options)
    if (o.name == name) return YAML::Load(o.default_yaml).as<double>();
  FAIL("no option " << name);
  return 0;
}
}  // namespace

TEST_CASE("ComponentInfo::extension finds an extension by type and returns nullptr when absent") {
  ComponentInfo info;
  CHECK(info.extension<RunContinuation>() == nullptr);
  auto other = std::make_shared<OtherExtension>();
  info.extensions.push_back(other);
  CHECK(info.extension<OtherExtension>() == other.get());
  CHECK(info.extension<RunContinuation>() == nullptr);
}

TEST_CASE("rssgd offers RunContinuation through the registry; bo and random do not") {
  const Registry& r = test::registry();
  CHECK(r.find(Kind::Algorithm, "rssgd").extension<RunContinuation>() != nullptr);
  CHECK(r.find(Kind::Algorithm, "bo").extension<RunContinuation>() == nullptr);
  CHECK(r.find(Kind::Algorithm, "random").extension<RunContinuation>() == nullptr);
}

TEST_CASE("rssgd's local model for a run of another algorithm is the one of an rssgd run at its defaults") {
  const Registry& r = test::registry();
  const ComponentInfo& rssgd = r.find(Kind::Algorithm, "rssgd");
  const RunContinuation& c = *rssgd.extension<RunContinuation>();
  const LocalModelSpec other = c.local_model(nullptr, r);
  CHECK(other.critic.info->name == "vhgp");
  CHECK(other.optimizer.info->name == "multistart");
  // ε = 3.5σ (Kuindersma 2013, section 5.4) at the declared default σ; the declared minimum of local points.
  CHECK(other.radius == doctest::Approx(3.5 * declared_default(rssgd, "sigma")).epsilon(1e-15));
  CHECK(other.min_points == static_cast<Index>(declared_default(rssgd, "min_local_points")));

  const ResolvedComponent own = r.resolve(Kind::Algorithm, ConfigNode::parse("{type: rssgd, epsilon: 0.3}", "<t>"));
  const LocalModelSpec m = c.local_model(&own.options, r);
  CHECK(m.radius == 0.3);
  CHECK(m.critic.info->name == "vhgp");
  const ResolvedComponent diag =
      r.resolve(Kind::Algorithm, ConfigNode::parse("{type: rssgd, sigma_diag: [0.05, 0.1]}", "<t>"));
  CHECK(c.local_model(&diag.options, r).radius == doctest::Approx(3.5 * 0.1).epsilon(1e-15));
}

TEST_CASE("rssgd's continued block: the given kappa and history, no phases or start, every trial a step") {
  const RunContinuation& c = *test::registry().find(Kind::Algorithm, "rssgd").extension<RunContinuation>();
  YAML::Node alg = YAML::Load("{type: rssgd, kappa: 0, phases: [{steps: 3, kappa: 1}], start: [0.5], eta: 0.4}");
  c.continue_from(alg, "/tmp/h.csv", 2.0);
  CHECK(alg["type"].as<std::string>() == "rssgd");
  CHECK(alg["eta"].as<double>() == 0.4);  // the run's other settings stay
  CHECK(alg["kappa"].as<double>() == 2.0);
  CHECK(alg["history"].as<std::string>() == "/tmp/h.csv");
  CHECK(alg["evaluate_initial"].as<bool>() == false);
  CHECK(!alg["phases"]);
  CHECK(!alg["start"]);
}
