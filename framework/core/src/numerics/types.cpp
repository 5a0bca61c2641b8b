#include "varbo/types.hpp"
#include "varbo/math.hpp"

#include <cmath>

namespace varbo {

Box Box::unit(Index d) { return Box{Vec::Zero(d), Vec::Ones(d)}; }

bool Box::contains(const Vec& x, double tol) const {
  if (x.size() != lower.size()) return false;
  for (Index i = 0; i < x.size(); ++i)
    if (!(x[i] >= lower[i] - tol && x[i] <= upper[i] + tol)) return false;
  return true;
}

Vec Box::clamp(const Vec& x) const { return x.cwiseMax(lower).cwiseMin(upper); }

void Dataset::add(const Vec& x, double cost) {
  const Index n = size();
  if (n == 0 && X.cols() == 0) X.resize(0, x.size());
  X.conservativeResize(n + 1, x.size());
  X.row(n) = x.transpose();
  y.conservativeResize(n + 1);
  y[n] = cost;
}

Dataset Dataset::empty(Index d) { return Dataset{Mat(0, d), Vec(0)}; }

std::uint64_t mix_seed(std::uint64_t a, std::uint64_t b, std::uint64_t c) {
  auto splitmix = [](std::uint64_t z) {
    z += 0x9e3779b97f4a7c15ULL;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  };
  return splitmix(splitmix(splitmix(a) ^ b) ^ (c * 0x632be59bd9b4e019ULL));
}

Rng::Rng(std::uint64_t seed) : seed_(seed), engine_(mix_seed(seed, 0x5eed)) {}

Rng Rng::stream(std::uint64_t a, std::uint64_t b) const { return Rng(mix_seed(seed_, a + 1, b + 1)); }

std::uint64_t Rng::next() { return engine_(); }

// Own transforms (not std::*_distribution) so streams are identical across standard libraries.
double Rng::uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
double Rng::uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }

double Rng::normal() {
  // Box–Muller; one value per call keeps the stream stateless between calls.
  double u1 = uniform();
  while (u1 <= 0.0) u1 = uniform();
  const double u2 = uniform();
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

Index Rng::index(Index n) { return n <= 1 ? 0 : static_cast<Index>(engine_() % static_cast<std::uint64_t>(n)); }

Vec Rng::uniform_vec(Index d) {
  Vec v(d);
  for (Index i = 0; i < d; ++i) v[i] = uniform();
  return v;
}

Vec Rng::normal_vec(Index d) {
  Vec v(d);
  for (Index i = 0; i < d; ++i) v[i] = normal();
  return v;
}

Vec to_unit(const Vec& theta, const Box& box) {
  return ((theta - box.lower).array() / (box.upper - box.lower).array()).matrix();
}
Vec from_unit(const Vec& u, const Box& box) {
  return box.lower + (u.array() * (box.upper - box.lower).array()).matrix();
}

}  // namespace varbo
