// Tests of the paper's tasks: the two-minima cost (definition, optima, noise statistics) and the
// pendulum swing-up (energy conservation, a closed-form episode, step-size convergence, determinism,
// and the paper's risk-averse / risk-seeking policies of section 5.2).
#include <cmath>
#include <numbers>

#include "pendulum.hpp"
#include "swingup.hpp"
#include "two_minima.hpp"
#include "varbo/errors.hpp"
#include "varbo_test.hpp"

using namespace varbo;
using namespace varbo::tasks;

namespace {
struct Stats {
  double mean, sd;
};
template <class F>
Stats stats(int n, F draw) {
  double s = 0, s2 = 0;
  for (int k = 0; k < n; ++k) {
    const double v = draw(k);
    s += v;
    s2 += v * v;
  }
  const double m = s / n;
  return {m, std::sqrt(std::max(0.0, s2 / n - m * m))};
}
}  // namespace

TEST_CASE("two_minima_1d: two minima of equal expected cost, different noise") {
  CHECK(two_minima_mean(0.25) == doctest::Approx(0.1).epsilon(1e-14));
  CHECK(two_minima_mean(0.75) == doctest::Approx(0.1).epsilon(1e-14));
  double lowest = INFINITY;
  for (int i = 0; i <= 100000; ++i) lowest = std::min(lowest, two_minima_mean(i / 100000.0));
  CHECK(lowest >= 0.1 - 1e-14);
  CHECK(two_minima_std(0.25) == doctest::Approx(0.0325).epsilon(1e-14));
  CHECK(two_minima_std(0.75) == doctest::Approx(0.1325).epsilon(1e-14));

  TwoMinimaTask task;
  const auto opt = task.optimum();
  REQUIRE(opt);
  CHECK(opt->cost == 0.1);
  REQUIRE(opt->thetas.size() == 2);
  CHECK(opt->thetas[0][0] == 0.25);
  CHECK(opt->thetas[1][0] == 0.75);
  CHECK(task.domain().names == std::vector<std::string>{"theta"});
  CHECK(task.domain().box.upper[0] == 1.0);

  // Noise: n = 20000 draws; SE of the mean s/√n, of the sd s/√(2n) (0.5 %); tolerances ≈ 4 SE.
  Rng rng(42);
  for (double t : {0.25, 0.75}) {
    CAPTURE(t);
    const Stats st = stats(20000, [&](int k) {
      Rng r = rng.stream(static_cast<std::uint64_t>(t * 100), static_cast<std::uint64_t>(k));
      const Evaluation e = task.evaluate(Vec::Constant(1, t), r);
      return e.cost;
    });
    CHECK(std::abs(st.mean - 0.1) < 4 * two_minima_std(t) / std::sqrt(20000.0));
    CHECK(std::abs(st.sd / two_minima_std(t) - 1) < 0.03);
  }
  TwoMinimaTask quiet(0.0);
  CHECK(quiet.evaluate(Vec::Constant(1, 0.6), rng).cost == two_minima_mean(0.6));
  CHECK(!task.evaluate(Vec::Zero(2), rng).ok);
}

TEST_CASE("pendulum: angle from upright and energy conservation without torque") {
  const double pi = std::numbers::pi;
  CHECK(angle_from_upright(0.0) == doctest::Approx(pi));
  CHECK(angle_from_upright(pi) == doctest::Approx(0.0));
  CHECK(angle_from_upright(-pi) == doctest::Approx(0.0));
  CHECK(angle_from_upright(3 * pi - 0.05) == doctest::Approx(0.05));
  CHECK(angle_from_upright(2 * pi + 0.3) == doctest::Approx(pi - 0.3));
  CHECK(angle_from_upright(-0.3) == doctest::Approx(pi - 0.3));

  PendulumParams p;
  for (PendulumState s : {PendulumState{2.5, 0.0}, PendulumState{0.1, 3.0}, PendulumState{0.0, 6.0}}) {
    const double e0 = pendulum_energy(p, s);
    double worst = 0;
    for (int k = 0; k < 2000; ++k) {  // 2 s at dt = 1 ms
      s = rk4_step(p, s, 0.0, 1e-3);
      worst = std::max(worst, std::abs(pendulum_energy(p, s) - e0));
    }
    // Relative to m g l; RK4's energy error at this step is ~1e-12.
    CHECK(worst / (p.mass * p.gravity * p.length) < 1e-9);
  }
}

TEST_CASE("swing-up: closed-form episode (no gravity, constant torque)") {
  // With g → 0 and u = τ throughout: φ = τt²/2, α = π − φ, the goal is reached at
  // t* = √(2(π − 0.1)/τ), and ∫α = π t* − τ t*³/6 — checks the RK4 integral and the goal-entry time.
  SwingupSettings s;
  s.pendulum.gravity = 1e-300;
  const double tau = 4.0, pi = std::numbers::pi;
  const SwingupResult r = simulate_swingup(10.0, 0.0, tau, s);  // t1 beyond T: +τ all along
  const double t_star = std::sqrt(2 * (pi - 0.1) / tau);
  CHECK(r.reached);
  CHECK(r.t_end == doctest::Approx(t_star).epsilon(1e-12));
  CHECK(r.angle_cost == doctest::Approx(0.01 * (pi * t_star - tau * t_star * t_star * t_star / 6)).epsilon(1e-10));
  CHECK(r.effort_cost == doctest::Approx(1e-4 * tau * tau * t_star).epsilon(1e-12));
  CHECK(r.swings == 1);
}

TEST_CASE("swing-up: bang-bang semantics of eq. (21)") {
  CHECK(bang_bang_torque(0.0, 0.5, 1.0, 4) == 4);
  CHECK(bang_bang_torque(0.5, 0.5, 1.0, 4) == 4);
  CHECK(bang_bang_torque(0.51, 0.5, 1.0, 4) == -4);
  CHECK(bang_bang_torque(1.5, 0.5, 1.0, 4) == -4);
  CHECK(bang_bang_torque(1.51, 0.5, 1.0, 4) == 4);
  CHECK(bang_bang_torque(0.1, 0.0, 1.0, 4) == -4);
}

TEST_CASE("swing-up: a policy that never reaches upright runs the full horizon") {
  SwingupSettings s;
  // t1 = t2 = 0: +τ from the start; τ = 4 Nm < m g l = 9.81 Nm, so the pendulum only rocks.
  const SwingupResult r = simulate_swingup(0.0, 0.0, 4.0, s);
  CHECK(!r.reached);
  CHECK(r.t_end == 3.5);
  CHECK(r.effort_cost == doctest::Approx(1e-4 * 16 * 3.5).epsilon(1e-14));
  CHECK(r.angle_cost > 0.01 * 2.0 * 3.5);  // never gets near upright
}

TEST_CASE("swing-up: the cost is converged in the step size") {
  SwingupSettings fine, coarse;
  fine.dt = coarse.dt / 2;
  double worst = 0;
  // Away from the thresholds where an episode switches between reaching and not reaching.
  const double policies[][3] = {{0.63, 1.14, 4.0}, {0.63, 1.14, 3.4}, {1.03, 1.5, 4.5}, {1.03, 1.5, 3.8},
                                {0.0, 1.0, 4.5},   {0.0, 0.0, 4.0},   {0.3, 0.9, 4.0},  {1.4, 0.2, 4.1}};
  for (const auto& q : policies) {
    const double a = simulate_swingup(q[0], q[1], q[2], coarse).cost;
    const double b = simulate_swingup(q[0], q[1], q[2], fine).cost;
    worst = std::max(worst, std::abs(a - b) / std::abs(b));
  }
  MESSAGE("largest relative change of the cost when halving dt = 1e-3: " << worst);
  CHECK(worst < 1e-4);
}

TEST_CASE("swing-up task: determinism, components, domain") {
  SwingupTask task{SwingupSettings{}};
  const Domain d = task.domain();
  CHECK(d.names == std::vector<std::string>{"t1", "t2"});
  CHECK(d.box.lower.isZero());
  CHECK(d.box.upper.isApproxToConstant(1.5));
  Vec theta(2);
  theta << 0.63, 1.14;
  Rng a(99), b(99), c(100);
  const Evaluation ea = task.evaluate(theta, a), eb = task.evaluate(theta, b), ec = task.evaluate(theta, c);
  REQUIRE(ea.ok);
  CHECK(ea.cost == eb.cost);
  CHECK(ea.components == eb.components);
  CHECK(ea.cost != ec.cost);  // a different τ_max
  REQUIRE(ea.components.size() == 2);
  CHECK(ea.components[0].first == "angle");
  CHECK(ea.components[1].first == "effort");
  CHECK(ea.components[0].second + ea.components[1].second == ea.cost);
  CHECK(task.component_names() == std::vector<std::string>{"angle", "effort"});
  Vec bad(2);
  bad << -0.1, 1.0;
  CHECK(!task.evaluate(bad, a).ok);
}

TEST_CASE("swing-up: the paper's risk-averse and risk-seeking policies (section 5.2, Fig. 4)") {
  SwingupSettings s;
  // Risk-averse θ ≈ [0.63, 1.14]: three swings, reaches upright for every τ_max of Fig. 4(a)–(e).
  for (double tau : {3.4, 3.7, 4.0, 4.3, 4.6}) {
    CAPTURE(tau);
    const SwingupResult r = simulate_swingup(0.63, 1.14, tau, s);
    CHECK(r.reached);
    CHECK(r.swings == 3);
  }
  // Risk-seeking θ ≈ [1.03, 1.5]: two swings when τ_max is large (≈ E + σ = 4.3 and above), else it
  // misses the goal region and runs to T.
  for (double tau : {4.3, 4.4, 4.5, 4.6}) {
    CAPTURE(tau);
    const SwingupResult r = simulate_swingup(1.03, 1.5, tau, s);
    CHECK(r.reached);
    CHECK(r.swings == 2);
    // ... and then it is cheaper than the risk-averse policy (paper: 13.03 vs 15.93).
    CHECK(r.cost < simulate_swingup(0.63, 1.14, tau, s).cost);
  }
  for (double tau : {3.4, 3.7, 4.0, 4.2}) {
    CAPTURE(tau);
    CHECK(!simulate_swingup(1.03, 1.5, tau, s).reached);
  }
  const double averse = simulate_swingup(0.63, 1.14, 4.4, s).cost, seeking = simulate_swingup(1.03, 1.5, 4.4, s).cost;
  MESSAGE("tau_max = 4.4: risk-averse cost " << averse << ", risk-seeking " << seeking << ", ratio "
                                              << averse / seeking << " (paper: 15.93 / 13.03 = 1.2226)");
  CHECK(averse / seeking == doctest::Approx(15.93 / 13.03).epsilon(0.02));

  // Over τ_max ~ N(4, 0.3²): the risk-averse policy has a much smaller cost spread.
  SwingupTask task(s);
  Rng rng(2013);
  Vec ta(2), ts(2);
  ta << 0.63, 1.14;
  ts << 1.03, 1.5;
  const Stats sa = stats(400, [&](int k) { Rng r = rng.stream(1, static_cast<std::uint64_t>(k)); return task.evaluate(ta, r).cost; });
  const Stats ss = stats(400, [&](int k) { Rng r = rng.stream(1, static_cast<std::uint64_t>(k)); return task.evaluate(ts, r).cost; });
  MESSAGE("400 episodes: risk-averse mean " << sa.mean << " sd " << sa.sd << "; risk-seeking mean " << ss.mean
                                            << " sd " << ss.sd);
  CHECK(sa.sd * 3 < ss.sd);
}

TEST_CASE("paper tasks through the registry: options") {
  Registry& reg = test::registry();
  BuildContext ctx;
  auto p = reg.create<Task>("pendulum_swingup", ctx);
  CHECK(p->domain().box.upper[1] == 1.5);
  auto q = reg.create<Task>("{type: pendulum_swingup, t_max: 2, tau_std: 0}", ctx);
  CHECK(q->domain().box.upper[0] == 2.0);
  Vec theta(2);
  theta << 0.63, 1.14;
  Rng r1(1), r2(2);
  CHECK(q->evaluate(theta, r1).cost == q->evaluate(theta, r2).cost);  // tau_std = 0: no randomness left
  auto t = reg.create<Task>("two_minima_1d", ctx);
  CHECK(t->optimum()->thetas.size() == 2);
  CHECK_THROWS_AS(reg.create<Task>("{type: pendulum_swingup, dt: 0}", ctx), ConfigError);
  CHECK_THROWS_AS(reg.create<Task>("{type: pendulum_swingup, dt: 0.5}", ctx), ConfigError);
  CHECK_THROWS_AS(reg.create<Task>("{type: pendulum_swingup, tau: 4}", ctx), ConfigError);
  CHECK_THROWS_AS(reg.create<Task>("{type: two_minima_1d, noise_scale: -1}", ctx), ConfigError);
}
