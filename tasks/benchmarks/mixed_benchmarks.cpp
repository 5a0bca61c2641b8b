// The mixed-space benchmarks (docs/search_space.md, "Benchmarks").
#include "mixed_benchmarks.hpp"

#include <fmt/format.h>

#include <cmath>
#include <limits>

#include "benchmark_functions.hpp"

namespace varbo::tasks {

namespace {

Parameter real(const std::string& n, double lo, double hi, bool log = false) {
  Parameter p;
  p.name = n;
  p.low = lo;
  p.high = hi;
  p.log = log;
  return p;
}
Parameter integer(const std::string& n, double lo, double hi) {
  Parameter p = real(n, lo, hi);
  p.type = ParameterType::Int;
  return p;
}
Parameter categorical(const std::string& n, std::vector<std::string> choices) {
  Parameter p;
  p.name = n;
  p.type = ParameterType::Categorical;
  p.choices = std::move(choices);
  return p;
}

// Ackley-5 over 3 categories (3 labels each) and 2 reals in [−4, 6]: label j of category i stands for the
// coordinate value kLevels[i][j]; the minimum 0 needs the label worth 0 in each and x = 0. The labels are not
// ordered by value, so an ordinal relaxation ("a < b < c") has nothing to follow.
constexpr double kLevels[3][3] = {{2.0, 0.0, 1.0}, {1.0, 2.0, 0.0}, {0.0, 1.0, 2.0}};
MixedBenchmark mixed_ackley() {
  MixedBenchmark b;
  b.name = "mixed_ackley";
  b.description = "Ackley-5 over 3 categories (labels a, b, c; unordered levels 0, 1, 2) and 2 reals in [-4, 6]; f* = 0";
  b.space = std::make_shared<const SearchSpace>(std::vector<Parameter>{
      categorical("c1", {"a", "b", "c"}), categorical("c2", {"a", "b", "c"}), categorical("c3", {"a", "b", "c"}),
      real("x1", -4, 6), real("x2", -4, 6)});
  b.f = [](const Vec& t) {
    Vec z(5);
    for (int i = 0; i < 3; ++i) z[i] = kLevels[i][static_cast<int>(std::lround(t[i]))];
    z[3] = t[3];
    z[4] = t[4];
    return ackley(z);
  };
  b.locate_minimum = [] { return Optimum{0, {(Vec(5) << 1, 2, 0, 0, 0).finished()}}; };
  return b;
}

// Rosenbrock-6 on the integers of [−5, 10]: f* = 0 at (1, ..., 1).
MixedBenchmark integer_rosenbrock() {
  MixedBenchmark b;
  b.name = "integer_rosenbrock";
  b.description = "Rosenbrock-6 on the integers of [-5, 10]; f* = 0 at (1, ..., 1)";
  std::vector<Parameter> ps;
  for (int i = 1; i <= 6; ++i) ps.push_back(integer(fmt::format("n{}", i), -5, 10));
  b.space = std::make_shared<const SearchSpace>(std::move(ps));
  b.f = [](const Vec& t) { return rosenbrock(t); };
  b.locate_minimum = [] { return Optimum{0, {Vec::Ones(6)}}; };
  return b;
}

// A tuning problem whose minimum needs a learning rate over 5 decades: the loss of a model trained with rate lr
// and momentum m, a valley in (log10 lr, m) whose floor drifts with the effective step lr/(1 − m):
//   f = (log10 lr + 3.3 + 0.8·(m − 0.5))² / 0.5 + (m − 0.85)² · 4 + 0.3·(1 − cos(2π(log10 lr + 3.3)))
// over lr ∈ [1e-6, 0.1] (log) and m ∈ [0, 0.99]. Its minimum, by construction at the valley floor, is computed
// numerically (a dense scan refined by golden sections) when the benchmark list is built.
double log_scale_f(const Vec& t) {
  const double l = std::log10(t[0]), m = t[1];
  const double u = l + 3.3 + 0.8 * (m - 0.5);
  return u * u / 0.5 + (m - 0.85) * (m - 0.85) * 4 + 0.3 * (1 - std::cos(2 * M_PI * (l + 3.3)));
}
MixedBenchmark log_scale() {
  MixedBenchmark b;
  b.name = "log_scale";
  b.description = "learning rate lr in [1e-6, 0.1] (log scale, 5 decades) and momentum m in [0, 0.99]; minimum "
                  "near lr = 4.4e-4, m = 0.78 (cost 0.0944)";
  b.space = std::make_shared<const SearchSpace>(std::vector<Parameter>{real("lr", 1e-6, 0.1, true), real("m", 0, 0.99)});
  b.f = log_scale_f;
  b.locate_minimum = [] {
    // Minimize on a grid over (log10 lr, m), then refine by coordinate golden sections.
    double best = std::numeric_limits<double>::infinity();
    Vec arg(2);
    for (int i = 0; i <= 2000; ++i)
      for (int j = 0; j <= 400; ++j) {
        const Vec t = (Vec(2) << std::pow(10.0, -6 + 5.0 * i / 2000), 0.99 * j / 400).finished();
        const double v = log_scale_f(t);
        if (v < best) {
          best = v;
          arg = t;
        }
      }
    for (int round = 0; round < 40; ++round)
      for (int k = 0; k < 2; ++k) {
        double a = k == 0 ? std::log10(arg[0]) - 0.01 : std::max(0.0, arg[1] - 0.01);
        double c = k == 0 ? std::log10(arg[0]) + 0.01 : std::min(0.99, arg[1] + 0.01);
        auto at = [&](double v) {
          Vec t = arg;
          if (k == 0) t[0] = std::pow(10.0, v);
          else t[1] = v;
          return t;
        };
        for (int it = 0; it < 60; ++it) {
          const double g = 0.381966 * (c - a);
          if (log_scale_f(at(a + g)) < log_scale_f(at(c - g))) c = c - g;
          else a = a + g;
        }
        const Vec t = at(0.5 * (a + c));
        if (log_scale_f(t) < best) {
          best = log_scale_f(t);
          arg = t;
        }
      }
    return Optimum{best, {arg}};
  };
  return b;
}

// Branin with x1 + x2 ≤ 4: the constraint cuts off all three unconstrained minimizers ((−π, 12.275): sum 9.1,
// (π, 2.275): 5.4, (9.42, 2.475): 11.9), so the minimum lies on the line x1 + x2 = 4 (Branin has no other
// local minimum inside); computed by a dense scan of that segment refined by golden sections.
MixedBenchmark branin_constrained() {
  MixedBenchmark b;
  b.name = "branin_constrained";
  b.description = "Branin on [-5, 10] x [0, 15] with the constraint x1 + x2 <= 4, which cuts off its three "
                  "unconstrained minimizers";
  SearchSpace s(std::vector<Parameter>{real("x1", -5, 10), real("x2", 0, 15)});
  s.add_constraint(parse_linear_constraint("x1 + x2 <= 4", s.parameters()));
  s.finalize();
  b.space = std::make_shared<const SearchSpace>(std::move(s));
  b.f = [](const Vec& t) { return branin(t); };
  b.locate_minimum = [] {
    // The feasible boundary: the segment x2 = 4 − x1, x1 ∈ [−5, 4], and the box edges inside the constraint.
    auto on_line = [](double x1) { return branin((Vec(2) << x1, 4 - x1).finished()); };
    double best = std::numeric_limits<double>::infinity(), arg1 = 0;
    for (int i = 0; i <= 90000; ++i) {
      const double x1 = -5 + 9.0 * i / 90000;
      if (on_line(x1) < best) {
        best = on_line(x1);
        arg1 = x1;
      }
    }
    double a = arg1 - 2e-4, c = arg1 + 2e-4;
    for (int it = 0; it < 80; ++it) {
      const double g = 0.381966 * (c - a);
      if (on_line(a + g) < on_line(c - g)) c = c - g;
      else a = a + g;
    }
    arg1 = 0.5 * (a + c);
    best = on_line(arg1);
    Vec arg = (Vec(2) << arg1, 4 - arg1).finished();
    // The interior and the other edges, on a grid (a check: the boundary minimum must be the lowest).
    for (int i = 0; i <= 600; ++i)
      for (int j = 0; j <= 600; ++j) {
        const Vec t = (Vec(2) << -5 + 15.0 * i / 600, 15.0 * j / 600).finished();
        if (t[0] + t[1] <= 4 && branin(t) < best) {
          best = branin(t);
          arg = t;
        }
      }
    return Optimum{best, {arg}};
  };
  return b;
}

}  // namespace

const Optimum& MixedBenchmark::minimum() const {
  std::call_once(located->once, [&] { located->value = locate_minimum(); });
  return located->value;
}

const std::vector<MixedBenchmark>& mixed_benchmarks() {
  static const std::vector<MixedBenchmark> all = {mixed_ackley(), integer_rosenbrock(), log_scale(), branin_constrained()};
  return all;
}

Evaluation MixedBenchmarkTask::evaluate(const Vec& theta, Rng& rng) {
  Evaluation e;
  std::string why;
  if (!b_.space->contains(theta, &why)) {
    e.ok = false;
    e.error = b_.name + ": inadmissible θ: " + why;
    return e;
  }
  e.cost = e.noiseless_cost = b_.f(theta);
  if (noise_std_ > 0) e.cost += noise_std_ * rng.normal();
  return e;
}

std::optional<double> MixedBenchmarkTask::noiseless_cost(const Vec& theta) const {
  if (theta.size() != static_cast<Index>(b_.space->size())) return std::nullopt;
  return b_.f(theta);
}

}  // namespace varbo::tasks
