#include "benchmark_functions.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>

namespace varbo::tasks {

namespace {
constexpr double pi = std::numbers::pi;

Box uniform_box(Index d, double lo, double hi) { return Box{Vec::Constant(d, lo), Vec::Constant(d, hi)}; }

// Hartmann family: f(x) = -Σ_i α_i exp(-Σ_j A_ij (x_j - P_ij)²).
template <int D>
double hartmann(const Vec& x, const double (&A)[4][D], const double (&P)[4][D]) {
  static constexpr double alpha[4] = {1.0, 1.2, 3.0, 3.2};
  double f = 0;
  for (int i = 0; i < 4; ++i) {
    double inner = 0;
    for (int j = 0; j < D; ++j) inner += A[i][j] * (x[j] - P[i][j]) * (x[j] - P[i][j]);
    f -= alpha[i] * std::exp(-inner);
  }
  return f;
}

// Hartmann minimizers: the published points polished by a local Nelder–Mead (xtol 1e-15) on the
// functions above. The published values are -3.86278 and -3.32237, which these round to.
constexpr double hartmann3_min = -3.8627797873326628;
constexpr double hartmann3_argmin[3] = {0.114588877023, 0.555648894881, 0.852546984227};
constexpr double hartmann6_min = -3.3223680114155156;
constexpr double hartmann6_argmin[6] = {0.201689511021, 0.150010692421, 0.476873973312,
                                        0.275332431357, 0.311651616879, 0.657300534875};

// The global minimizer of x⁴ - 16x² + 5x: the negative root of 4x³ - 32x + 5 = 0, polished by Newton
// from the published value -2.903534 (full double precision).
double styblinski_tang_root() {
  double x = -2.903534;
  for (int k = 0; k < 20; ++k) x -= (4 * x * x * x - 32 * x + 5) / (12 * x * x - 32);
  return x;
}
}  // namespace

// Branin-Hoo (Surjanovic & Bingham, https://www.sfu.ca/~ssurjano/branin.html), standard constants:
// a=1, b=5.1/(4π²), c=5/π, r=6, s=10, t=1/(8π). Domain x1 ∈ [-5, 10], x2 ∈ [0, 15].
double branin(const Vec& x) {
  const double b = 5.1 / (4 * pi * pi), c = 5 / pi, r = 6, s = 10, t = 1 / (8 * pi);
  const double q = x[1] - b * x[0] * x[0] + c * x[0] - r;
  return q * q + s * (1 - t) * std::cos(x[0]) + s;
}

// Hartmann 3-D (https://www.sfu.ca/~ssurjano/hart3.html), domain [0, 1]³.
double hartmann3(const Vec& x) {
  static constexpr double A[4][3] = {{3.0, 10, 30}, {0.1, 10, 35}, {3.0, 10, 30}, {0.1, 10, 35}};
  static constexpr double P[4][3] = {{0.3689, 0.1170, 0.2673},
                                     {0.4699, 0.4387, 0.7470},
                                     {0.1091, 0.8732, 0.5547},
                                     {0.0381, 0.5743, 0.8828}};
  return hartmann<3>(x, A, P);
}

// Hartmann 6-D (https://www.sfu.ca/~ssurjano/hart6.html), domain [0, 1]⁶. This is the unscaled form
// whose minimum is -3.32237 (the site also lists a rescaled variant; we use the common unscaled one).
double hartmann6(const Vec& x) {
  static constexpr double A[4][6] = {{10, 3, 17, 3.5, 1.7, 8},
                                     {0.05, 10, 17, 0.1, 8, 14},
                                     {3, 3.5, 1.7, 10, 17, 8},
                                     {17, 8, 0.05, 10, 0.1, 14}};
  static constexpr double P[4][6] = {{0.1312, 0.1696, 0.5569, 0.0124, 0.8283, 0.5886},
                                     {0.2329, 0.4135, 0.8307, 0.3736, 0.1004, 0.9991},
                                     {0.2348, 0.1451, 0.3522, 0.2883, 0.3047, 0.6650},
                                     {0.4047, 0.8828, 0.8732, 0.5743, 0.1091, 0.0381}};
  return hartmann<6>(x, A, P);
}

// Ackley (https://www.sfu.ca/~ssurjano/ackley.html): a=20, b=0.2, c=2π, domain [-32.768, 32.768]^d.
double ackley(const Vec& x) {
  const double a = 20, b = 0.2, c = 2 * pi;
  const double d = static_cast<double>(x.size());
  const double sq = x.squaredNorm() / d;
  const double cs = (c * x.array()).cos().sum() / d;
  return -a * std::exp(-b * std::sqrt(sq)) - std::exp(cs) + a + std::numbers::e;
}

// Rosenbrock (https://www.sfu.ca/~ssurjano/rosen.html), domain [-5, 10]^d.
double rosenbrock(const Vec& x) {
  double f = 0;
  for (Index i = 0; i + 1 < x.size(); ++i) {
    const double u = x[i + 1] - x[i] * x[i], v = x[i] - 1;
    f += 100 * u * u + v * v;
  }
  return f;
}

// Levy (https://www.sfu.ca/~ssurjano/levy.html), w_i = 1 + (x_i - 1)/4, domain [-10, 10]^d.
double levy(const Vec& x) {
  const Index d = x.size();
  auto w = [&](Index i) { return 1 + (x[i] - 1) / 4; };
  const double s1 = std::sin(pi * w(0));
  double f = s1 * s1;
  for (Index i = 0; i + 1 < d; ++i) {
    const double wi = w(i), si = std::sin(pi * wi + 1);
    f += (wi - 1) * (wi - 1) * (1 + 10 * si * si);
  }
  const double wd = w(d - 1), sd = std::sin(2 * pi * wd);
  return f + (wd - 1) * (wd - 1) * (1 + sd * sd);
}

// Styblinski–Tang (https://www.sfu.ca/~ssurjano/stybtang.html), domain [-5, 5]^d.
double styblinski_tang(const Vec& x) {
  const auto a = x.array();
  return 0.5 * (a.pow(4) - 16 * a.square() + 5 * a).sum();
}

const std::vector<BenchmarkSpec>& benchmark_specs() {
  static const std::vector<BenchmarkSpec> specs = [] {
    std::vector<BenchmarkSpec> s;
    {
      BenchmarkSpec b;
      b.name = "branin";
      b.description = "Branin-Hoo, 2-D, x1 in [-5,10], x2 in [0,15], f* = 5/(4 pi) = 0.397887 at three points";
      b.fixed_dim = 2;
      b.f = branin;
      b.domain = [](Index) {
        Box box{Vec(2), Vec(2)};
        box.lower << -5, 0;
        box.upper << 10, 15;
        return box;
      };
      // At the minimizers the squared term vanishes and cos(x1) = -1, leaving s·t = 10/(8π).
      b.min_value = [](Index) { return 10 / (8 * pi); };
      // x1 ∈ {-π, π, 3π}, x2 = b x1² - c x1 + r: exactly 12.275, 2.275, 2.475.
      b.argmins = [](Index) {
        Vec a(2), c(2), e(2);
        a << -pi, 12.275;
        c << pi, 2.275;
        e << 3 * pi, 2.475;
        return std::vector<Vec>{a, c, e};
      };
      s.push_back(b);
    }
    {
      BenchmarkSpec b;
      b.name = "hartmann3";
      b.description = "Hartmann 3-D on [0,1]^3, f* = -3.86278";
      b.fixed_dim = 3;
      b.f = hartmann3;
      b.domain = [](Index d) { return uniform_box(d, 0, 1); };
      // Published x* = (0.114614, 0.555649, 0.852547), f* = -3.86278; polished digits above.
      b.min_value = [](Index) { return hartmann3_min; };
      b.argmins = [](Index) {
        return std::vector<Vec>{Eigen::Map<const Vec>(hartmann3_argmin, 3)};
      };
      s.push_back(b);
    }
    {
      BenchmarkSpec b;
      b.name = "hartmann6";
      b.description = "Hartmann 6-D on [0,1]^6, f* = -3.32237";
      b.fixed_dim = 6;
      b.f = hartmann6;
      b.domain = [](Index d) { return uniform_box(d, 0, 1); };
      // Published x* = (0.20169, 0.150011, 0.476874, 0.275332, 0.311652, 0.6573), f* = -3.32237;
      // polished digits above.
      b.min_value = [](Index) { return hartmann6_min; };
      b.argmins = [](Index) {
        return std::vector<Vec>{Eigen::Map<const Vec>(hartmann6_argmin, 6)};
      };
      s.push_back(b);
    }
    {
      BenchmarkSpec b;
      b.name = "ackley";
      b.description = "Ackley (a=20, b=0.2, c=2 pi), d-D on [-32.768,32.768]^d, f* = 0 at 0";
      b.min_dim = 1;
      b.default_dim = 5;
      b.f = ackley;
      b.domain = [](Index d) { return uniform_box(d, -32.768, 32.768); };
      b.min_value = [](Index) { return 0.0; };
      b.argmins = [](Index d) { return std::vector<Vec>{Vec::Zero(d)}; };
      s.push_back(b);
    }
    {
      BenchmarkSpec b;
      b.name = "rosenbrock";
      b.description = "Rosenbrock, d-D (d >= 2) on [-5,10]^d, f* = 0 at (1,...,1)";
      b.min_dim = 2;
      b.default_dim = 2;
      b.f = rosenbrock;
      b.domain = [](Index d) { return uniform_box(d, -5, 10); };
      b.min_value = [](Index) { return 0.0; };
      b.argmins = [](Index d) { return std::vector<Vec>{Vec::Ones(d)}; };
      s.push_back(b);
    }
    {
      BenchmarkSpec b;
      b.name = "levy";
      b.description = "Levy, d-D on [-10,10]^d, f* = 0 at (1,...,1)";
      b.min_dim = 1;
      b.default_dim = 2;
      b.f = levy;
      b.domain = [](Index d) { return uniform_box(d, -10, 10); };
      b.min_value = [](Index) { return 0.0; };
      b.argmins = [](Index d) { return std::vector<Vec>{Vec::Ones(d)}; };
      s.push_back(b);
    }
    {
      BenchmarkSpec b;
      b.name = "styblinski_tang";
      b.description = "Styblinski-Tang, d-D on [-5,5]^d, f* = -39.16616570377142 d at x_i = -2.903534";
      b.min_dim = 1;
      b.default_dim = 2;
      b.f = styblinski_tang;
      b.domain = [](Index d) { return uniform_box(d, -5, 5); };
      // ½(x⁴ - 16x² + 5x) at the root above, times d (the site rounds it to -39.16599 d).
      b.min_value = [](Index d) {
        const double r = styblinski_tang_root();
        return 0.5 * (r * r * r * r - 16 * r * r + 5 * r) * static_cast<double>(d);
      };
      b.argmins = [](Index d) { return std::vector<Vec>{Vec::Constant(d, styblinski_tang_root())}; };
      s.push_back(b);
    }
    return s;
  }();
  return specs;
}

const BenchmarkSpec& benchmark_spec(const std::string& name) {
  for (const auto& s : benchmark_specs())
    if (s.name == name) return s;
  throw std::out_of_range("no benchmark named '" + name + "'");
}

}  // namespace varbo::tasks
