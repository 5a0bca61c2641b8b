#include "noisy_functions.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <stdexcept>

#include "benchmark_functions.hpp"

namespace varbo::tasks::noisy {

namespace {
constexpr double pi = std::numbers::pi;

Box cube(Index d, double lo, double hi) { return Box{Vec::Constant(d, lo), Vec::Constant(d, hi)}; }

/// i/(d-1), the exponent fraction of BBOB's conditioning diagonals (0 when d = 1).
double frac(Index i, Index d) { return d > 1 ? static_cast<double>(i) / static_cast<double>(d - 1) : 0.0; }

/// BBOB's Λ^α: diag(α^{i/(2(d-1))}).
Vec lambda_diag(double alpha, Index d) {
  Vec l(d);
  for (Index i = 0; i < d; ++i) l[i] = std::pow(alpha, 0.5 * frac(i, d));
  return l;
}

/// The instance's own stream: fixed by (function id, instance, d), independent of any study seed.
Rng instance_rng(std::uint64_t function_id, long instance, Index d) {
  return Rng(mix_seed(0x6e6f697379ULL /* "noisy" */ + function_id, static_cast<std::uint64_t>(instance),
                      static_cast<std::uint64_t>(d)));
}

/// Fisher-Yates with the framework's own draws (std::shuffle's algorithm differs between standard libraries).
template <class T>
void shuffle(std::vector<T>& v, Rng& rng) {
  for (std::size_t i = v.size(); i > 1; --i) std::swap(v[i - 1], v[static_cast<std::size_t>(rng.index(static_cast<Index>(i)))]);
}

Vec uniform_in(Rng& rng, Index d, double lo, double hi) {
  Vec v(d);
  for (Index i = 0; i < d; ++i) v[i] = rng.uniform(lo, hi);
  return v;
}

/// The common BBOB shape: f(x) = g(x - x_opt), x_opt ~ U[-r, r]^d, domain [-5, 5]^d, f* = 0 at x_opt.
FunctionInstance shifted(std::function<double(const Vec&)> g, Vec xopt) {
  FunctionInstance fi;
  const Index d = xopt.size();
  fi.box = cube(d, -5, 5);
  fi.fstar = 0;
  fi.argmins = {xopt};
  fi.f = [g = std::move(g), xopt = std::move(xopt)](const Vec& x) { return g(x - xopt); };
  return fi;
}

// ---- the BBOB-style functions (BBOB 2009 function numbers in brackets) ----

// Sphere [f1]: ||z||².
FunctionInstance make_sphere(Index d, long k) {
  Rng rng = instance_rng(1, k, d);
  return shifted([](const Vec& z) { return z.squaredNorm(); }, uniform_in(rng, d, -4, 4));
}

// Rosenbrock [f8]: Σ 100(z_i² - z_{i+1})² + (z_i - 1)², z = max(1, √d/8)(x - x_opt) + 1, x_opt ~ U[-3, 3]^d
// (BBOB's 0.75 factor keeps the curved valley inside the box). Reuses tasks/benchmarks' rosenbrock.
FunctionInstance make_rosenbrock(Index d, long k) {
  Rng rng = instance_rng(2, k, d);
  const double c = std::max(1.0, std::sqrt(static_cast<double>(d)) / 8);
  return shifted([c](const Vec& z) { return tasks::rosenbrock((c * z.array() + 1).matrix()); },
                 uniform_in(rng, d, -3, 3));
}

// Rotated ellipsoid with condition 1e4 [as in the noisy suite's f116-118]: Σ 10^{4 i/(d-1)} z_i², z = R(x - x_opt).
FunctionInstance make_ellipsoid(Index d, long k) {
  Rng rng = instance_rng(3, k, d);
  Vec xopt = uniform_in(rng, d, -4, 4);
  Mat R = random_rotation(d, rng);
  Vec w(d);
  for (Index i = 0; i < d; ++i) w[i] = std::pow(10.0, 4 * frac(i, d));
  return shifted([R, w](const Vec& x) { return w.dot((R * x).array().square().matrix()); }, std::move(xopt));
}

// Step ellipsoid [f7]: ẑ = Λ^10 R(x - x_opt); z̃_i = round(ẑ_i) if |ẑ_i| > 0.5 else round(10 ẑ_i)/10; z = Q z̃;
// f = 0.1 max(|ẑ_1|/1e4, Σ 10^{2 i/(d-1)} z_i²). Plateaus everywhere; f = 0 on a neighbourhood of x_opt.
FunctionInstance make_step_ellipsoid(Index d, long k) {
  Rng rng = instance_rng(4, k, d);
  Vec xopt = uniform_in(rng, d, -4, 4);
  Mat R = random_rotation(d, rng), Q = random_rotation(d, rng);
  const Vec l = lambda_diag(10, d);
  Vec w(d);
  for (Index i = 0; i < d; ++i) w[i] = std::pow(10.0, 2 * frac(i, d));
  auto g = [R, Q, l, w](const Vec& x) {
    const Vec zh = l.cwiseProduct(R * x);
    Vec zt(zh.size());
    for (Index i = 0; i < zh.size(); ++i)
      zt[i] = std::abs(zh[i]) > 0.5 ? std::floor(0.5 + zh[i]) : std::floor(0.5 + 10 * zh[i]) / 10;
    const Vec z = Q * zt;
    return 0.1 * std::max(std::abs(zh[0]) / 1e4, w.dot(z.array().square().matrix()));
  };
  return shifted(g, std::move(xopt));
}

// Rastrigin [f3 without T_osz, T_asy, Λ^10]: 10(d - Σ cos 2π z_i) + ||z||², z = x - x_opt.
FunctionInstance make_rastrigin(Index d, long k) {
  Rng rng = instance_rng(5, k, d);
  auto g = [](const Vec& z) {
    return 10 * (static_cast<double>(z.size()) - (2 * pi * z.array()).cos().sum()) + z.squaredNorm();
  };
  return shifted(g, uniform_in(rng, d, -4, 4));
}

// Schaffer F7 [f17 without T_asy, Q = I]: z = Λ^10 R(x - x_opt), s_i = √(z_i² + z_{i+1}²),
// f = ((1/(d-1)) Σ_{i<d} (√s_i + √s_i sin²(50 s_i^0.2)))².
FunctionInstance make_schaffer(Index d, long k) {
  Rng rng = instance_rng(6, k, d);
  Vec xopt = uniform_in(rng, d, -4, 4);
  Mat R = random_rotation(d, rng);
  const Vec l = lambda_diag(10, d);
  auto g = [R, l](const Vec& x) {
    const Vec z = l.cwiseProduct(R * x);
    double sum = 0;
    for (Index i = 0; i + 1 < z.size(); ++i) {
      const double s = std::hypot(z[i], z[i + 1]);
      const double t = std::sin(50 * std::pow(s, 0.2));
      sum += std::sqrt(s) * (1 + t * t);
    }
    const double m = sum / static_cast<double>(z.size() - 1);
    return m * m;
  };
  return shifted(g, std::move(xopt));
}

// Griewank-Rosenbrock F8F2 [f19]: z = max(1, √d/8) R(x - x_opt) + 1, s_i = 100(z_i² - z_{i+1})² + (z_i - 1)²,
// f = 10/(d-1) Σ (s_i/4000 - cos s_i) + 10 (≥ 0, since s/4000 - cos s > -1 for s > 0), x_opt ~ U[-3, 3]^d.
FunctionInstance make_griewank_rosenbrock(Index d, long k) {
  Rng rng = instance_rng(7, k, d);
  Vec xopt = uniform_in(rng, d, -3, 3);
  Mat R = random_rotation(d, rng);
  const double c = std::max(1.0, std::sqrt(static_cast<double>(d)) / 8);
  auto g = [R, c](const Vec& x) {
    const Vec z = (c * (R * x)).array() + 1;
    double sum = 0;
    for (Index i = 0; i + 1 < z.size(); ++i) {
      const double u = z[i] * z[i] - z[i + 1], v = z[i] - 1;
      const double s = 100 * u * u + v * v;
      sum += s / 4000 - std::cos(s);
    }
    return 10 * sum / static_cast<double>(z.size() - 1) + 10;
  };
  return shifted(g, std::move(xopt));
}

// Gallagher's Gaussian peaks, 21 peaks [f22 without T_osz]:
// f = (10 - max_i w_i exp(-(1/(2d)) (x - y_i)ᵀ Rᵀ C_i R (x - y_i)))², w_1 = 10, w_i = 1.1 + 8(i-2)/19;
// C_i = Λ^{α_i}/α_i^{1/4} with its diagonal randomly permuted, α_1 = 1000², α_{2..21} a random permutation of
// {1000^{2j/19}: j = 0..19}; y_1 ~ U[-3.92, 3.92]^d, the others ~ U[-4.9, 4.9]^d. The other peaks reach at most
// 9.1 < 10, so the only global minimizer is y_1, f* = 0.
FunctionInstance make_gallagher(Index d, long k) {
  Rng rng = instance_rng(8, k, d);
  constexpr int n = 21;
  Mat R = random_rotation(d, rng);
  std::vector<int> order(n - 1);
  std::iota(order.begin(), order.end(), 0);
  shuffle(order, rng);
  std::vector<double> w(n), alpha(n);
  std::vector<Vec> y(n), c(n);
  for (int i = 0; i < n; ++i) {
    w[static_cast<std::size_t>(i)] = i == 0 ? 10.0 : 1.1 + 8.0 * (i - 1) / (n - 2);
    alpha[static_cast<std::size_t>(i)] = i == 0 ? 1e6 : std::pow(1000.0, 2.0 * order[static_cast<std::size_t>(i - 1)] / (n - 2));
    y[static_cast<std::size_t>(i)] = i == 0 ? uniform_in(rng, d, -3.92, 3.92) : uniform_in(rng, d, -4.9, 4.9);
    const double a = alpha[static_cast<std::size_t>(i)];
    Vec diag = lambda_diag(a, d) / std::pow(a, 0.25);
    // As in BBOB, Λ^α = diag(α^{i/(2(d-1))}) enters the quadratic form directly (not squared).
    std::vector<Index> perm(static_cast<std::size_t>(d));
    std::iota(perm.begin(), perm.end(), Index{0});
    shuffle(perm, rng);
    Vec permuted(d);
    for (Index j = 0; j < d; ++j) permuted[j] = diag[perm[static_cast<std::size_t>(j)]];
    c[static_cast<std::size_t>(i)] = permuted;
  }
  FunctionInstance fi;
  fi.box = cube(d, -5, 5);
  fi.fstar = 0;
  fi.argmins = {y[0]};
  fi.f = [R, w, y, c](const Vec& x) {
    const double inv2d = 1.0 / (2.0 * static_cast<double>(x.size()));
    double best = 0;
    for (std::size_t i = 0; i < w.size(); ++i) {
      const Vec r = R * (x - y[i]);
      best = std::max(best, w[i] * std::exp(-inv2d * c[i].dot(r.array().square().matrix())));
    }
    const double t = 10 - best;
    return t * t;
  };
  return fi;
}

// ---- the two classic functions, from tasks/benchmarks, with reflected (Hartmann-6: also permuted)
// coordinates per instance; instance 1 is the standard function. ----

// Branin on [-5, 10] x [0, 15]: x1 -> 5 - x1 and x2 -> 15 - x2 map the box onto itself; instance k >= 2 applies
// each with probability 1/2 (so there are 4 distinct layouts). f* = 5/(4π) at three points.
FunctionInstance make_branin(Index d, long k) {
  const auto& spec = tasks::benchmark_spec("branin");
  Rng rng = instance_rng(9, k, d);
  const bool r1 = k > 1 && rng.uniform() < 0.5, r2 = k > 1 && rng.uniform() < 0.5;
  auto t = [r1, r2](const Vec& x) {
    Vec y = x;
    if (r1) y[0] = 5 - x[0];
    if (r2) y[1] = 15 - x[1];
    return y;
  };
  FunctionInstance fi;
  fi.box = spec.domain(2);
  fi.fstar = spec.min_value(2);
  for (const Vec& a : spec.argmins(2)) fi.argmins.push_back(t(a));  // t is an involution
  fi.f = [t](const Vec& x) { return tasks::branin(t(x)); };
  return fi;
}

// Hartmann-6 on [0, 1]^6: instance k >= 2 evaluates H6(T x) with T x_j = x_{π(j)} or 1 - x_{π(j)} (a seeded
// permutation π and reflection of each coordinate with probability 1/2). f* = -3.32237.
FunctionInstance make_hartmann6(Index d, long k) {
  const auto& spec = tasks::benchmark_spec("hartmann6");
  Rng rng = instance_rng(10, k, d);
  std::vector<Index> perm(6);
  std::iota(perm.begin(), perm.end(), Index{0});
  std::vector<bool> flip(6, false);
  if (k > 1) {
    shuffle(perm, rng);
    for (std::size_t j = 0; j < 6; ++j) flip[j] = rng.uniform() < 0.5;
  }
  auto t = [perm, flip](const Vec& x) {
    Vec y(6);
    for (std::size_t j = 0; j < 6; ++j) {
      const double v = x[perm[j]];
      y[static_cast<Index>(j)] = flip[j] ? 1 - v : v;
    }
    return y;
  };
  FunctionInstance fi;
  fi.box = spec.domain(6);
  fi.fstar = spec.min_value(6);
  for (const Vec& a : spec.argmins(6)) {
    Vec x(6);  // solve T x = a: x_{π(j)} = a_j or 1 - a_j
    for (std::size_t j = 0; j < 6; ++j) x[perm[j]] = flip[j] ? 1 - a[static_cast<Index>(j)] : a[static_cast<Index>(j)];
    fi.argmins.push_back(x);
  }
  fi.f = [t](const Vec& x) { return tasks::hartmann6(t(x)); };
  return fi;
}

NoisyFunctionSpec spec(std::string name, std::string description, Index fixed_dim, Index min_dim,
                       FunctionInstance (*make)(Index, long)) {
  NoisyFunctionSpec s;
  s.name = std::move(name);
  s.description = std::move(description);
  s.fixed_dim = fixed_dim;
  s.min_dim = min_dim;
  s.make = make;
  return s;
}
}  // namespace

Mat random_rotation(Index d, Rng& rng) {
  Mat g(d, d);
  for (Index j = 0; j < d; ++j)
    for (Index i = 0; i < d; ++i) g(i, j) = rng.normal();
  Eigen::HouseholderQR<Mat> qr(g);
  Mat q = qr.householderQ();
  const Mat r = qr.matrixQR().triangularView<Eigen::Upper>();
  for (Index j = 0; j < d; ++j)
    if (r(j, j) < 0) q.col(j) *= -1;
  return q;
}

const std::vector<NoisyFunctionSpec>& noisy_function_specs() {
  static const std::vector<NoisyFunctionSpec> specs = {
      spec("sphere", "||x - x_opt||^2 on [-5,5]^d, f* = 0", 0, 1, make_sphere),
      spec("rosenbrock", "BBOB f8 Rosenbrock on [-5,5]^d (d >= 2), f* = 0", 0, 2, make_rosenbrock),
      spec("ellipsoid", "rotated ellipsoid, condition 1e4, on [-5,5]^d, f* = 0", 0, 1, make_ellipsoid),
      spec("step_ellipsoid", "BBOB f7 step ellipsoid (plateaus) on [-5,5]^d, f* = 0", 0, 1, make_step_ellipsoid),
      spec("rastrigin", "separable Rastrigin (BBOB f3 without transforms) on [-5,5]^d, f* = 0", 0, 1, make_rastrigin),
      spec("schaffer", "BBOB f17 Schaffer F7, condition 10, on [-5,5]^d (d >= 2), f* = 0", 0, 2, make_schaffer),
      spec("griewank_rosenbrock", "BBOB f19 composite Griewank-Rosenbrock on [-5,5]^d (d >= 2), f* = 0", 0, 2,
           make_griewank_rosenbrock),
      spec("gallagher", "BBOB f22 Gallagher's 21 Gaussian peaks on [-5,5]^d, f* = 0", 0, 1, make_gallagher),
      spec("branin", "Branin-Hoo (d = 2), x1 in [-5,10], x2 in [0,15], f* = 5/(4 pi) = 0.397887", 2, 2, make_branin),
      spec("hartmann6", "Hartmann-6 (d = 6) on [0,1]^6, f* = -3.32237", 6, 6, make_hartmann6),
  };
  return specs;
}

const NoisyFunctionSpec& noisy_function_spec(const std::string& name) {
  for (const auto& s : noisy_function_specs())
    if (s.name == name) return s;
  throw std::out_of_range("no noisy-suite function named '" + name + "'");
}

std::vector<std::string> noisy_function_names() {
  std::vector<std::string> n;
  for (const auto& s : noisy_function_specs()) n.push_back(s.name);
  return n;
}

}  // namespace varbo::tasks::noisy
