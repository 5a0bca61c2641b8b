#pragma once
// Basic value types shared by every component: vectors, boxes, data sets and seeded random streams.
#include <Eigen/Dense>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

namespace varbo {

using Vec = Eigen::VectorXd;
using Mat = Eigen::MatrixXd;
using Index = Eigen::Index;

/// Axis-aligned box [lower, upper]. Inside the framework every domain is the unit cube.
struct Box {
  Vec lower;
  Vec upper;
  static Box unit(Index d);
  Index dim() const { return lower.size(); }
  bool contains(const Vec& x, double tol = 0.0) const;
  Vec clamp(const Vec& x) const;
  Vec width() const { return upper - lower; }
};

/// Observations in the unit cube: row i of X is θ_i, y(i) its cost.
struct Dataset {
  Mat X;
  Vec y;
  Index size() const { return y.size(); }
  Index dim() const { return X.cols(); }
  void add(const Vec& x, double cost);
  static Dataset empty(Index d);
};

/// A seeded, splittable random stream. Streams derived with `stream(a, b)` are independent of the
/// order in which they are created, which makes parallel restarts deterministic whatever the thread count.
class Rng {
 public:
  explicit Rng(std::uint64_t seed = 0);
  Rng stream(std::uint64_t a, std::uint64_t b = 0) const;
  std::uint64_t seed() const { return seed_; }
  double uniform();                 ///< U[0, 1)
  double uniform(double lo, double hi);
  double normal();                  ///< N(0, 1)
  Index index(Index n);             ///< uniform in {0, ..., n-1}
  Vec uniform_vec(Index d);
  Vec normal_vec(Index d);
  std::uint64_t next();
  std::mt19937_64& engine() { return engine_; }

 private:
  std::uint64_t seed_;
  std::mt19937_64 engine_;
};

/// SplitMix64 mixing of several words into one seed.
std::uint64_t mix_seed(std::uint64_t a, std::uint64_t b = 0, std::uint64_t c = 0);

}  // namespace varbo
