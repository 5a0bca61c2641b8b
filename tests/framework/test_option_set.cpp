// Options bound to settings structs: each default comes from the struct, one read() fills it, and the specs
// are exactly those of the unbound builders (so --describe and messages do not change).
#include <optional>
#include <string>

#include "varbo/errors.hpp"
#include "varbo/option_set.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {
enum class Method { Lbfgs, Slsqp, Cobyla };

struct Inner {
  double tol = 1e-8;
  long evaluations = 500;
};

struct Settings {
  bool warm = true;
  int restarts = 4;
  long samples = 2000;
  std::size_t count = 7;
  double xi = 0.01;
  std::string name = "x";
  std::string command;  // empty: no default
  std::string kernel = "se_ard";
  Method method = Method::Slsqp;
  std::vector<double> bounds{0, 1.5};
  std::vector<double> center;  // empty: no default
  std::optional<double> radius;
  std::optional<int> seed;
  std::optional<std::vector<double>> start;
  Inner local{1e-7, 200};  // the outer struct gives the inner one other defaults
  double not_an_option = 3.0;
};

const OptionSet<Settings>& settings_options() {
  static const OptionSet<Settings> set{
      opt::boolean("warm", &Settings::warm, "warm start"),
      opt::integer("restarts", &Settings::restarts, "restarts").at_least(1).at_most(64),
      opt::integer("samples", &Settings::samples, "samples").at_least(1),
      opt::integer("count", &Settings::count, "count").at_least(0),
      opt::real("xi", &Settings::xi, "exploration").at_least(0),
      opt::string("name", &Settings::name, "a name"),
      opt::string("command", &Settings::command, "a command"),
      opt::choice("kernel", &Settings::kernel, {"se_ard", "matern52_ard"}, "kernel"),
      opt::choice("method", &Settings::method,
                  {{"lbfgs", Method::Lbfgs}, {"slsqp", Method::Slsqp}, {"cobyla", Method::Cobyla}}, "method"),
      opt::reals("bounds", &Settings::bounds, "bounds"),
      opt::reals("center", &Settings::center, "centre"),
      opt::real("radius", &Settings::radius, "radius").above(0),
      opt::integer("seed", &Settings::seed, "seed"),
      opt::reals("start", &Settings::start, "start"),
      opt::real("tol", opt::nested(&Settings::local, &Inner::tol), "local tolerance").above(0),
      opt::integer("evaluations", opt::nested(&Settings::local, &Inner::evaluations), "local evaluations").at_least(1),
      opt::node("extra", "", "read by hand")};
  return set;
}

Options validate(const std::string& yaml) {
  return validate_options(ConfigNode::parse(yaml, "c.yaml"), settings_options().specs(), "algorithm 'x'", nullptr);
}

std::string error_of(const std::string& yaml) {
  try {
    settings_options().read(validate(yaml));
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

const OptionSpec& spec(const std::string& name) {
  for (const auto& s : settings_options().options())
    if (s.spec().name == name) return s.spec();
  throw std::logic_error("no spec " + name);
}
}  // namespace

TEST_CASE("a bound spec is the unbound builder's spec with the struct's default") {
  // Independent reference: the hand-written declarations these replace.
  const std::vector<OptionSpec> by_hand{
      opt::boolean("warm", true, "warm start"),
      opt::integer("restarts", 4, "restarts").at_least(1).at_most(64),
      opt::integer("samples", 2000, "samples").at_least(1),
      opt::integer("count", 7, "count").at_least(0),
      opt::real("xi", 0.01, "exploration").at_least(0),
      opt::string("name", "x", "a name"),
      opt::string("command", "", "a command"),
      opt::choice("kernel", "se_ard", {"se_ard", "matern52_ard"}, "kernel"),
      opt::choice("method", "slsqp", {"lbfgs", "slsqp", "cobyla"}, "method"),
      opt::reals("bounds", "[0, 1.5]", "bounds"),
      opt::reals("center", "", "centre"),
      opt::real("radius", 0.0, "radius").above(0),
      opt::integer("seed", 0, "seed"),
      opt::reals("start", "", "start"),
      opt::real("tol", 1e-7, "local tolerance").above(0),
      opt::integer("evaluations", 200, "local evaluations").at_least(1),
      opt::node("extra", "", "read by hand")};
  const auto bound = settings_options().specs();
  REQUIRE(bound.size() == by_hand.size());
  for (std::size_t i = 0; i < bound.size(); ++i) {
    INFO(by_hand[i].name);
    CHECK(bound[i].name == by_hand[i].name);
    CHECK(bound[i].type == by_hand[i].type);
    CHECK(bound[i].description == by_hand[i].description);
    CHECK(bound[i].expected() == by_hand[i].expected());
    CHECK(bound[i].required == by_hand[i].required);
    CHECK(bound[i].choices == by_hand[i].choices);
    // radius and seed: optional fields without a value in S{} have no default (by_hand writes 0 for them).
    if (by_hand[i].name == "radius" || by_hand[i].name == "seed")
      CHECK(bound[i].default_yaml.empty());
    else
      CHECK(bound[i].default_yaml == by_hand[i].default_yaml);
  }
  CHECK(settings_options().options().back().bound() == false);  // the node is declared, not bound
}

TEST_CASE("read() with nothing given gives a default-constructed struct") {
  const Settings d;
  const Settings s = settings_options().read(validate("{}"));
  CHECK(s.warm == d.warm);
  CHECK(s.restarts == d.restarts);
  CHECK(s.samples == d.samples);
  CHECK(s.count == d.count);
  CHECK(s.xi == d.xi);
  CHECK(s.name == d.name);
  CHECK(s.command.empty());
  CHECK(s.kernel == d.kernel);
  CHECK(s.method == d.method);
  CHECK(s.bounds == d.bounds);
  CHECK(s.center.empty());
  CHECK_FALSE(s.radius.has_value());
  CHECK_FALSE(s.seed.has_value());
  CHECK_FALSE(s.start.has_value());
  CHECK(s.local.tol == d.local.tol);
  CHECK(s.local.evaluations == d.local.evaluations);
  // The resolved config (config.resolved.yaml) shows the struct's defaults.
  const YAML::Node r = validate("{}").resolved();
  CHECK(r["xi"].as<double>() == 0.01);
  CHECK(r["method"].as<std::string>() == "slsqp");
  CHECK(r["tol"].as<double>() == 1e-7);
  CHECK_FALSE(r["radius"].IsDefined());
}

TEST_CASE("read() copies every given value into its field") {
  const Settings s = settings_options().read(validate(
      "{warm: false, restarts: 9, samples: 12, count: 3, xi: 0.5, name: y, command: ls, kernel: matern52_ard, "
      "method: cobyla, bounds: [-1, 2], center: [0.25], radius: 0.125, seed: -4, start: [], tol: 0.001, "
      "evaluations: 17, extra: {a: 1}}"));
  CHECK_FALSE(s.warm);
  CHECK(s.restarts == 9);
  CHECK(s.samples == 12);
  CHECK(s.count == 3u);
  CHECK(s.xi == 0.5);
  CHECK(s.name == "y");
  CHECK(s.command == "ls");
  CHECK(s.kernel == "matern52_ard");
  CHECK(s.method == Method::Cobyla);
  CHECK(s.bounds == std::vector<double>{-1, 2});
  CHECK(s.center == std::vector<double>{0.25});
  REQUIRE(s.radius.has_value());
  CHECK(*s.radius == 0.125);
  REQUIRE(s.seed.has_value());
  CHECK(*s.seed == -4);
  REQUIRE(s.start.has_value());  // a given empty list is a value, not "unset"
  CHECK(s.start->empty());
  CHECK(s.local.tol == 0.001);
  CHECK(s.local.evaluations == 17);
  CHECK(s.not_an_option == 3.0);
}

TEST_CASE("bounds and choices of bound options are validated with the usual messages") {
  CHECK(error_of("restarts: 0\n") == "c.yaml:1:11: key 'restarts': expected an integer in [1, 64], got '0'");
  CHECK(error_of("restarts: 65\n") == "c.yaml:1:11: key 'restarts': expected an integer in [1, 64], got '65'");
  CHECK(error_of("xi: -1\n") == "c.yaml:1:5: key 'xi': expected a real number in [0, inf), got '-1'");
  CHECK(error_of("radius: 0\n") == "c.yaml:1:9: key 'radius': expected a real number in (0, inf), got '0'");
  CHECK(error_of("method: bfgs\n").find("c.yaml:1:9: key 'method': expected one of: lbfgs, slsqp, cobyla") == 0);
  CHECK(spec("restarts").expected() == "an integer in [1, 64]");
}

TEST_CASE("an integer that does not fit its field is refused at its position") {
  CHECK(error_of("seed: 3000000000\n").find("c.yaml:1:7: key 'seed': expected an integer that fits the setting") == 0);
  CHECK(error_of("count: -1\n").find("c.yaml:1:8: key 'count': expected an integer in [0, inf)") == 0);
}

TEST_CASE("a check that fails on a default option points at the user's map; no value holds a NUL") {
  const std::vector<OptionSpec> specs = {opt::real("lo", 1.0, "low"), opt::real("hi", 2.0, "high"),
                                         opt::string("path", "", "a path")};
  const ConfigNode file = ConfigNode::parse("owner:\n  lo: 5\n", "c.yaml");
  const Options o = validate_options(file.child("owner"), specs, "x", nullptr);
  CHECK(!o.given("hi"));
  try {
    o.node("hi").fail("expected hi > lo");
    FAIL("no error");
  } catch (const ConfigError& e) {
    // The map that left `hi` out starts at line 2, column 3; before, "<default of x>:1:1".
    CHECK(std::string(e.what()) == "c.yaml:2:3: key 'owner.hi': expected hi > lo");
  }
  CHECK(o.real("hi") == 2.0);  // the value is still the default's
  std::string what;
  try {
    ConfigNode::parse("path: \"out\\0x\"\n", "c.yaml");
  } catch (const ConfigError& e) {
    what = e.what();
  }
  CHECK(what == "c.yaml:1:7: a NUL byte (\\0) at offset 3 of this value; no setting holds one");
}

TEST_CASE("a required bound option shows no default and must be given") {
  struct Cmd {
    std::string command = "true";
  };
  const OptionSet<Cmd> set{opt::string("command", &Cmd::command, "shell command").must()};
  CHECK(set.specs()[0].default_yaml.empty());
  CHECK(set.specs()[0].required);
  CHECK_THROWS_AS(validate_options(ConfigNode::parse("{}", "c.yaml"), set.specs(), "task 'x'", nullptr), ConfigError);
  CHECK(set.read(validate_options(ConfigNode::parse("{command: ls}", "c.yaml"), set.specs(), "task 'x'", nullptr))
            .command == "ls");
}

TEST_CASE("an option read only when given: no default shown or resolved, the field keeps the component's value") {
  struct Floor {
    double min_noise = 1e-6;  // the component's value when the key is absent (gp: decided by the kernel)
  };
  const OptionSet<Floor> set{opt::real("min_noise", &Floor::min_noise, "floor").above(0).when_given()};
  CHECK(set.specs()[0].default_yaml.empty());
  CHECK_FALSE(set.specs()[0].required);
  const Options unset = validate_options(ConfigNode::parse("{}", "c.yaml"), set.specs(), "surrogate 'x'", nullptr);
  CHECK_FALSE(unset.is_set("min_noise"));
  CHECK_FALSE(unset.resolved()["min_noise"]);  // stays out of config.resolved.yaml
  Floor decided{1e-7};                         // e.g. set by the component before reading
  set.read_into(unset, decided);
  CHECK(decided.min_noise == 1e-7);
  const Options given =
      validate_options(ConfigNode::parse("{min_noise: 1.0e-4}", "c.yaml"), set.specs(), "surrogate 'x'", nullptr);
  set.read_into(given, decided);
  CHECK(decided.min_noise == 1e-4);
  CHECK(given.resolved()["min_noise"].as<double>() == 1e-4);
  // Its bounds still hold when given.
  CHECK_THROWS_AS(validate_options(ConfigNode::parse("{min_noise: 0}", "c.yaml"), set.specs(), "surrogate 'x'", nullptr),
                  ConfigError);
}

TEST_CASE("programming errors in a binding are logic errors, not config errors") {
  struct Bad {
    std::string kernel = "rbf";
    Method method = static_cast<Method>(42);
  };
  // A default outside the choices, an enum default without a name.
  CHECK_THROWS_AS(opt::choice("kernel", &Bad::kernel, {"se_ard"}, "k"), std::logic_error);
  CHECK_THROWS_AS(opt::choice("method", &Bad::method, {{"lbfgs", Method::Lbfgs}}, "m"), std::logic_error);
  // A field bound to an option missing from the validated specs (options checked against other specs).
  const Options other = validate_options(ConfigNode::parse("{}", "c.yaml"), {opt::real("xi", 0.5, "x")}, "x", nullptr);
  CHECK_THROWS_AS(settings_options().read(other), std::logic_error);
}
