#pragma once
// Standard global-optimization test functions with their usual domains and known optima.
// Definitions, domains and optima follow Surjanovic & Bingham, "Virtual Library of Simulation
// Experiments: Test Functions and Datasets" (https://www.sfu.ca/~ssurjano/optimization.html),
// cited per function in benchmark_functions.cpp.
#include <functional>
#include <string>
#include <vector>

#include "varbo/types.hpp"

namespace varbo::tasks {

double branin(const Vec& x);           // d = 2
double hartmann3(const Vec& x);        // d = 3
double hartmann6(const Vec& x);        // d = 6
double ackley(const Vec& x);           // any d >= 1
double rosenbrock(const Vec& x);       // any d >= 2
double levy(const Vec& x);             // any d >= 1
double styblinski_tang(const Vec& x);  // any d >= 1

/// Everything a benchmark task needs to know about one function.
struct BenchmarkSpec {
  std::string name;
  std::string description;
  Index fixed_dim = 0;    ///< > 0: the function is defined only for this dimension
  Index min_dim = 1;      ///< for d-dimensional functions
  Index default_dim = 2;  ///< for d-dimensional functions
  std::function<double(const Vec&)> f;
  /// Standard domain for dimension d (user units).
  std::function<Box(Index d)> domain;
  /// Known global minimum value for dimension d.
  std::function<double(Index d)> min_value;
  /// All global minimizers for dimension d (user units).
  std::function<std::vector<Vec>(Index d)> argmins;
};

/// The seven benchmarks, in a fixed order.
const std::vector<BenchmarkSpec>& benchmark_specs();
const BenchmarkSpec& benchmark_spec(const std::string& name);  // throws std::out_of_range

}  // namespace varbo::tasks
