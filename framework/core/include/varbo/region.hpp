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

/// Optional mixin of a region that restarts its search afresh, as TuRBO does after its trust region collapses
/// (Eriksson et al. 2019, section 2): from the trial at which fresh_starts() grows, the algorithm draws a new
/// initial design and models only the observations made since (the region then centres on their best). The
/// study keeps every observation, and so does the recommendation. Found with dynamic_cast, like
/// ComponentState, so regions without it need nothing.
class FreshStartRegion {
 public:
  virtual ~FreshStartRegion();
  /// How many fresh starts the region has asked for so far.
  virtual int fresh_starts() const = 0;
  /// The end of the search afresh (e.g. the last trials of the budget): the region goes back to the incumbent
  /// of all the data, to refine the best basin found, and asks for no more fresh starts. Idempotent.
  virtual void return_to_incumbent() = 0;
};

}  // namespace varbo
