#pragma once
// The set of θ the acquisition search may propose: a box, optionally with one smooth constraint c(θ) ≥ 0.
#include <string>
#include "varbo/surrogate.hpp"

namespace varbo {

/// Threads: update() is called from one thread; the const methods (bounds, constraint, contains, seeds) from
/// many threads at once (parallel samplers and optimizers).
class RegionConstraint {
 public:
  virtual ~RegionConstraint();
  /// Called after every fit.
  virtual void update(const Surrogate* model, const Dataset& data, Rng& rng);
  /// The box (unit cube coordinates).
  virtual const Box& bounds() const = 0;
  /// True when constraint() restricts the box further.
  virtual bool has_constraint() const { return false; }
  /// c(x) ≥ 0 inside; gradient filled when grad is non-null.
  virtual double constraint(const Vec& x, Vec* grad) const;
  bool contains(const Vec& x, double tol = 0.0) const;
  /// Feasible starting points for samplers and local searches (e.g. the data), rows are points.
  virtual Mat seeds() const { return Mat(0, bounds().dim()); }
  virtual std::string state() const { return {}; }
};

}  // namespace varbo
