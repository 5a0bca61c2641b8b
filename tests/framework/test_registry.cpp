// Registry: lookup by short and full name, unknown and ambiguous names, capability matching.
#include <new>
#include <stdexcept>

#include "varbo/errors.hpp"
#include "varbo/registry.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {
class ConstantAcquisition final : public Acquisition {
 public:
  explicit ConstantAcquisition(double v) : v_(v) {}
  void prepare(const AcquisitionContext&) override {}
  double evaluate(const Vec& x, Vec* g) const override {
    if (g) *g = Vec::Zero(x.size());
    return v_;
  }

 private:
  double v_;
};

ComponentInfo constant(const std::string& name) {
  return make_component<Acquisition>(name, "a constant", {opt::real("value", 1.0, "the value")},
                                     Factory<Acquisition>([](const Options& o, const BuildContext&) {
                                       return std::make_unique<ConstantAcquisition>(o.real("value"));
                                     }));
}
}  // namespace

TEST_CASE("components resolve by short name and by plugin/name; options are validated") {
  Registry r;
  PluginRegistrar(r, "p1", "libp1.so").add(constant("const"));
  auto a = r.create<Acquisition>("{type: const, value: 3}", BuildContext{});
  CHECK(a->evaluate(Vec::Zero(1), nullptr) == 3.0);
  auto b = r.create<Acquisition>("p1/const", BuildContext{});
  CHECK(b->evaluate(Vec::Zero(1), nullptr) == 1.0);
  CHECK_THROWS_AS(r.create<Acquisition>("{type: const, valeu: 3}", BuildContext{}), ConfigError);
}

TEST_CASE("an unknown name lists the known ones and suggests the nearest") {
  Registry r;
  r.add(constant("const"));
  r.add(constant("other"));
  try {
    r.resolve(Kind::Acquisition, ConfigNode::parse("{type: konst}", "a.yaml"));
    FAIL("expected UnknownComponentError");
  } catch (const UnknownComponentError& e) {
    CHECK(std::string(e.what()) ==
          "a.yaml:1:8: key 'type': unknown acquisition 'konst'. Known: const, other; did you mean 'const'?");
  }
  CHECK_THROWS_AS(r.find(Kind::Surrogate, "const"), UnknownComponentError);
}

TEST_CASE("a short name shared by two plugins is ambiguous; full names still work") {
  Registry r;
  PluginRegistrar(r, "a", "liba.so").add(constant("c"));
  PluginRegistrar b(r, "b", "libb.so");
  b.add(constant("c"));
  CHECK_THROWS_WITH_AS(r.find(Kind::Acquisition, "c"), "acquisition name 'c' is ambiguous; use one of: a/c, b/c",
                       UnknownComponentError);
  CHECK(r.find(Kind::Acquisition, "b/c").plugin == "b");
  CHECK_THROWS_AS(b.add(constant("c")), PluginLoadError);  // duplicate b/c
}

TEST_CASE("a factory of the wrong kind is refused at registration") {
  Registry r;
  ComponentInfo info = constant("x");
  info.kind = Kind::Surrogate;
  CHECK_THROWS_AS(r.add(info), PluginLoadError);
}

TEST_CASE("capability tags decide compatibility") {
  ComponentInfo region = constant("r");
  region.needs = {"optimizer:constraints"};
  ComponentInfo good = constant("g");
  good.provides = {"optimizer:constraints"};
  ComponentInfo plain = constant("p");
  std::string why;
  CHECK(compatible({&region, &good}, &why));
  CHECK_FALSE(compatible({&region, &plain}, &why));
  CHECK(why == "acquisition 'r' requires 'optimizer:constraints'");
}

TEST_CASE("a factory's standard exception becomes a ConfigError at the component; varbo errors and bad_alloc pass") {
  Registry r;
  PluginRegistrar third(r, "third", "libvarbo_third.so");
  third.add(make_component<Acquisition>("refuses", "throws std::invalid_argument", {opt::real("value", 1.0, "v")},
                                    Factory<Acquisition>([](const Options&, const BuildContext&)
                                                             -> std::unique_ptr<Acquisition> {
                                      throw std::invalid_argument("value must be negative");
                                    })));
  third.add(make_component<Acquisition>("says_where", "throws a ConfigError at its key", {opt::real("value", 1.0, "v")},
                                    Factory<Acquisition>([](const Options& o, const BuildContext&)
                                                             -> std::unique_ptr<Acquisition> {
                                      o.node("value").fail("expected a prime");
                                    })));
  third.add(make_component<Acquisition>("out_of_memory", "throws std::bad_alloc", {},
                                    Factory<Acquisition>([](const Options&, const BuildContext&)
                                                             -> std::unique_ptr<Acquisition> {
                                      throw std::bad_alloc();
                                    })));
  // A component whose factory creates another (as bo creates its acquisition): the inner one is named.
  third.add(make_component<Algorithm>(
      "outer", "creates an acquisition", {opt::component("acquisition", Kind::Acquisition, "refuses", "inner")},
      Factory<Algorithm>([](const Options& o, const BuildContext& ctx) -> std::unique_ptr<Algorithm> {
        ctx.registry->create<Acquisition>(o.component("acquisition"), ctx);
        return nullptr;
      })));
  auto message = [&](auto&& make) {
    try {
      make();
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("(no ConfigError)");
  };
  const ConfigNode cfg = ConfigNode::parse("a: {type: refuses, value: 3}\nb: {type: says_where, value: 4}\n"
                                           "c: {type: outer, acquisition: {type: refuses}}\nd: refuses\n",
                                           "s.yaml");
  CHECK(message([&] { r.create<Acquisition>(r.resolve(Kind::Acquisition, cfg.child("a")), BuildContext{}); }) ==
        "s.yaml:1:4: key 'a': acquisition 'third/refuses' (from libvarbo_third.so) could not be created: "
        "value must be negative");
  CHECK(message([&] { r.create<Acquisition>(r.resolve(Kind::Acquisition, cfg.child("b")), BuildContext{}); }) ==
        "s.yaml:2:30: key 'b.value': expected a prime");
  CHECK(message([&] { r.create<Algorithm>(r.resolve(Kind::Algorithm, cfg.child("c")), BuildContext{}); }) ==
        "s.yaml:3:31: key 'c.acquisition': acquisition 'third/refuses' (from libvarbo_third.so) could not be "
        "created: value must be negative");
  CHECK(message([&] { r.create<Acquisition>(r.resolve(Kind::Acquisition, cfg.child("d")), BuildContext{}); }) ==
        "s.yaml:4:4: key 'd': acquisition 'third/refuses' (from libvarbo_third.so) could not be created: "
        "value must be negative");
  CHECK_THROWS_AS(r.create<Acquisition>("out_of_memory", BuildContext{}), std::bad_alloc);
}

TEST_CASE("a plugin's registrar records its components under its own name and file, whatever they claim") {
  Registry r;
  PluginRegistrar mine(r, "mine", "libvarbo_mine.so");
  ComponentInfo forged = constant("forged");
  forged.plugin = "acquisitions";  // pretends to be a built-in plugin's component
  forged.library = "/usr/lib/varbo/plugins/libvarbo_acquisitions.so";
  mine.add(forged);
  const ComponentInfo& c = r.find(Kind::Acquisition, "forged");
  CHECK(c.plugin == "mine");
  CHECK(c.library == "libvarbo_mine.so");
  CHECK(c.full_name() == "mine/forged");
  CHECK(r.try_find(Kind::Acquisition, "acquisitions/forged") == nullptr);
}
