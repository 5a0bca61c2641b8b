// Tests of the `noisy` task: through the registry (options, defaults, bad input), the noise-free path
// (noiseless_cost = f = Evaluation::noiseless_cost), optimum(), determinism given the trial's stream.
#include <cmath>

#include <fmt/format.h>

#include "noisy_factory.hpp"
#include "noisy_task.hpp"
#include "varbo/errors.hpp"
#include "varbo_test.hpp"

using namespace varbo;
using namespace varbo::tasks::noisy;

namespace {
Vec random_in(const Box& b, Rng& rng) {
  return (b.lower.array() + rng.uniform_vec(b.dim()).array() * b.width().array()).matrix();
}
std::string error_of(const std::string& yaml) {
  try {
    test::registry().create<Task>(yaml, BuildContext{});
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}
bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }
}  // namespace

TEST_CASE("the noisy task through the registry") {
  Registry& reg = test::registry();
  BuildContext ctx;
  SUBCASE("defaults: noise-free sphere, d = 2, [-5, 5]^2") {
    auto t = reg.create<Task>("{type: noisy}", ctx);
    CHECK(t->domain().box.dim() == 2);
    CHECK(t->domain().box.lower.isApproxToConstant(-5));
    REQUIRE(t->optimum().has_value());
    CHECK(t->optimum()->cost == 0.0);
  }
  SUBCASE("the brief's example, and the fixed-dimension functions") {
    auto t = reg.create<Task>("{type: noisy, function: rosenbrock, dim: 5, noise: multiplicative, level: severe}", ctx);
    CHECK(t->domain().box.dim() == 5);
    CHECK(reg.create<Task>("{type: noisy, function: branin}", ctx)->domain().box.dim() == 2);
    CHECK(reg.create<Task>("{type: noisy, function: hartmann6, noise: cauchy}", ctx)->domain().box.dim() == 6);
    CHECK(reg.create<Task>("{type: noisy, function: hartmann6, dim: 6}", ctx)->domain().box.dim() == 6);
  }
  SUBCASE("bad options: a ConfigError naming the key and the expected form") {
    CHECK(contains(error_of("{type: noisy, function: bohachevsky}"), "function"));
    CHECK(contains(error_of("{type: noisy, noise: gaussian}"), "noise"));
    CHECK(contains(error_of("{type: noisy, level: extreme}"), "level"));
    CHECK(contains(error_of("{type: noisy, instance: 0}"), "instance"));
    CHECK(contains(error_of("{type: noisy, dim: 0}"), "dim"));
    const std::string e1 = error_of("{type: noisy, function: branin, dim: 5}");
    CHECK(contains(e1, "'dim'"));
    CHECK(contains(e1, "only for dim = 2"));
    const std::string e2 = error_of("{type: noisy, function: rosenbrock, dim: 1}");
    CHECK(contains(e2, "'dim'"));
    CHECK(contains(e2, "dim >= 2"));
    CHECK(contains(error_of("{type: noisy, levels: severe}"), "unknown key"));
  }
}

TEST_CASE("noise-free path: noiseless_cost(θ) = f(θ) = Evaluation::noiseless_cost, for every model") {
  Registry& reg = test::registry();
  for (const auto& noise : noise_model_names()) {
    for (const std::string fn : {"sphere", "gallagher", "hartmann6"}) {
      CAPTURE(noise);
      CAPTURE(fn);
      auto t = reg.create<Task>(fmt::format("{{type: noisy, function: {}, {}noise: {}, level: severe, instance: 2}}",
                                            fn, fn == "hartmann6" ? "" : "dim: 3, ", noise),
                                BuildContext{});
      auto* nt = dynamic_cast<NoisyTask*>(t.get());
      REQUIRE(nt != nullptr);
      Rng rng(21);
      for (int i = 0; i < 50; ++i) {
        const Vec x = random_in(t->domain().box, rng);
        const double f = nt->function().f(x);
        REQUIRE(t->noiseless_cost(x).has_value());
        CHECK(*t->noiseless_cost(x) == f);
        Rng trial = rng.stream(static_cast<std::uint64_t>(i));
        const Evaluation e = t->evaluate(x, trial);
        CHECK(e.ok);
        CHECK(e.noiseless_cost == f);
        CHECK(std::isfinite(e.cost));
        if (noise == "none") CHECK(e.cost == f);
      }
      // At a minimizer, the noise-free cost is f* (the regret of a perfect recommendation is 0).
      const auto opt = t->optimum();
      REQUIRE(opt.has_value());
      for (const Vec& x : opt->thetas) CHECK(std::abs(*t->noiseless_cost(x) - opt->cost) <= 1e-12);
      CHECK(!t->noiseless_cost(Vec::Zero(7)).has_value());
      Rng r(1);
      CHECK(!t->evaluate(Vec::Zero(7), r).ok);
    }
  }
}

TEST_CASE("determinism: the same trial stream gives the same cost; another stream another cost") {
  Registry& reg = test::registry();
  for (const auto& noise : noise_model_names()) {
    if (noise == "none") continue;
    CAPTURE(noise);
    const std::string yaml = fmt::format("{{type: noisy, function: ellipsoid, dim: 4, noise: {}, level: severe}}", noise);
    auto a = reg.create<Task>(yaml, BuildContext{});
    auto b = reg.create<Task>(yaml, BuildContext{});
    Rng pick(3);
    const Vec x = random_in(a->domain().box, pick);
    const Rng base(77);
    int differ = 0;
    for (std::uint64_t k = 0; k < 20; ++k) {
      Rng s1 = base.stream(k), s2 = base.stream(k), s3 = base.stream(k + 100);
      const double c1 = a->evaluate(x, s1).cost;
      CHECK(c1 == b->evaluate(x, s2).cost);
      differ += c1 != a->evaluate(x, s3).cost;
    }
    CHECK(differ >= 3);  // even cauchy (p = 0.2) differs on some of 20 streams; the others on all
  }
}
