// Tests of the gantry transport task: physics (energy conservation, equilibrium), the reference trajectory,
// cost = Σ w·components, determinism per trial stream, and that the task separates good and bad policies.
#include <cmath>

#include "gantry.hpp"
#include "reference_trajectory.hpp"
#include "transport_task.hpp"
#include "varbo/errors.hpp"
#include "varbo_test.hpp"

using namespace varbo;
using namespace varbo::transport;

namespace {
GantryState rk4(const GantryParams& p, const GantryState& s, double h) {
  auto add = [](const GantryState& a, const GantryState& k, double c) {
    return GantryState{a[0] + c * k[0], a[1] + c * k[1], a[2] + c * k[2], a[3] + c * k[3]};
  };
  const auto k1 = gantry_derivative(p, s, 0), k2 = gantry_derivative(p, add(s, k1, h / 2), 0);
  const auto k3 = gantry_derivative(p, add(s, k2, h / 2), 0), k4 = gantry_derivative(p, add(s, k3, h), 0);
  GantryState out;
  for (int i = 0; i < 4; ++i) out[i] = s[i] + h / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]);
  return out;
}
}  // namespace

TEST_CASE("unforced, undamped gantry conserves energy under RK4") {
  GantryParams p;
  p.cart_friction = 0;
  p.pivot_damping = 0;
  GantryState s{0.0, 0.3, 0.8, -0.5};
  const double e0 = gantry_energy(p, s);
  for (int k = 0; k < 1000; ++k) s = rk4(p, s, 0.01);  // 10 s
  // RK4 at h = 0.01 s: energy drift measured ~1e-9 relative; stated tolerance 1e-6.
  CHECK(std::abs(gantry_energy(p, s) - e0) <= 1e-6 * std::abs(e0));
}

TEST_CASE("hanging at rest is an equilibrium, and momentum balance holds for a pushed cart") {
  GantryParams p;
  const auto d = gantry_derivative(p, {0.2, 0, 0, 0}, 0);
  for (double v : d) CHECK(v == doctest::Approx(0.0));
  // A horizontal force on the hanging system at rest accelerates the cart: ẍ = F / M (the rod is vertical,
  // the load initially only swings back: φ̈ = −ẍ / l).
  const auto f = gantry_derivative(p, {0, 0, 0, 0}, 3.0);
  CHECK(f[1] == doctest::Approx(3.0 / p.cart_mass));
  CHECK(f[3] == doctest::Approx(-3.0 / p.cart_mass / p.rod_length));
}

TEST_CASE("reference trajectory passes through its knots with tangent-method velocities") {
  const ReferenceTrajectory r({0.0, 0.5, 1.2, 1.0, 1.5}, {1.0, 0.5, 0.5, 1.0});
  double x = 0, v = 0;
  r.at(0.0, x, v);
  CHECK(x == 0.0);
  CHECK(v == 0.0);
  r.at(1.0, x, v);
  CHECK(x == doctest::Approx(0.5));
  CHECK(v == doctest::Approx(0.5 * (0.5 + 1.4)));  // slopes 0.5 and 1.4 have the same sign
  r.at(1.5, x, v);
  CHECK(x == doctest::Approx(1.2));
  CHECK(v == doctest::Approx(0.0));  // slopes 1.4 and −0.4 change sign
  r.at(10.0, x, v);
  CHECK(x == 1.5);
  CHECK(v == 0.0);
  // Velocity is the derivative of position (central difference, h = 1e-6; tolerance 1e-6).
  double xa = 0, xb = 0, va = 0;
  r.at(0.7 - 1e-6, xa, va);
  r.at(0.7 + 1e-6, xb, va);
  r.at(0.7, x, v);
  CHECK(v == doctest::Approx((xb - xa) / 2e-6).epsilon(1e-6));
}

TEST_CASE("cost is the weighted sum of the components, and each trial stream is deterministic") {
  TransportSettings s;
  TransportTask task(s);
  const Vec theta0 = *task.initial_point();
  CHECK(task.domain().box.contains(theta0));
  Rng a(3), b(3);
  const Evaluation e1 = task.evaluate(theta0, a), e2 = task.evaluate(theta0, b);
  REQUIRE(e1.ok);
  CHECK(e1.cost == e2.cost);
  REQUIRE(e1.components.size() == 3);
  double sum = 0;
  for (const auto& [n, v] : e1.components) sum += s.weights.at(n) * v;
  CHECK(e1.cost == sum);
  Vec bad = theta0;
  bad[4] = -1;
  CHECK_FALSE(task.evaluate(bad, a).ok);
}

TEST_CASE("a fast transfer beats the slow hand-made policy on tracking but costs more energy and variance") {
  TransportSettings s;
  TransportTask task(s);
  const Vec slow = *task.initial_point();
  Vec fast = slow;
  fast.tail(4).setConstant(0.35);
  auto stats = [&](const Vec& th, int comp) {
    double m = 0, m2 = 0;
    const int n = 40;
    for (int i = 0; i < n; ++i) {
      Rng r = Rng(17).stream(static_cast<std::uint64_t>(i));
      const Evaluation e = task.evaluate(th, r);
      const double v = comp < 0 ? e.cost : e.components[static_cast<std::size_t>(comp)].second;
      m += v;
      m2 += v * v;
    }
    m /= n;
    return std::pair<double, double>{m, std::sqrt(std::max(0.0, m2 / n - m * m))};
  };
  CHECK(stats(fast, 0).first < stats(slow, 0).first);    // tracking
  CHECK(stats(fast, 2).first > stats(slow, 2).first);    // energy
  CHECK(stats(fast, -1).second > stats(slow, -1).second); // cost std: aggressive motions are riskier
}

TEST_CASE("the task plugin validates its weights") {
  Registry& r = test::registry();
  BuildContext ctx;
  CHECK_NOTHROW(r.create<Task>("{type: cartpole_transport, weights: {energy: 0.1}}", ctx));
  CHECK_THROWS_AS(r.create<Task>("{type: cartpole_transport, weights: {power: 0.1}}", ctx), ConfigError);
  CHECK_THROWS_AS(r.create<Task>("{type: cartpole_transport, weights: {energy: -1}}", ctx), ConfigError);
}
