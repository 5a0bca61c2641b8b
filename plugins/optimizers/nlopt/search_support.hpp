#pragma once
// Helpers shared by the optimizers of this plugin: feasible start points and parallel, deterministic
// evaluation of many candidates.
#include <initializer_list>

#include "varbo/function.hpp"
#include "varbo/optimizer.hpp"
#include "varbo/region.hpp"

namespace varbo::nlopt_plugin {

/// The rows of X clamped into the region's box, keeping only those inside its constraint.
Mat feasible_rows(const RegionConstraint& region, const Mat& X);

/// Values of f (no gradient) at the rows of X, −inf where f is not finite. Evaluated in parallel chunks;
/// slot i is written only by its own chunk, so the result does not depend on the thread count.
Vec evaluate_rows(const DifferentiableFunction& f, const Mat& X);

/// Index of the largest value (the first one on ties), −1 when all are −inf.
Index best_index(const Vec& values);

/// The region's seeds, or else one feasible point: the box centre or a uniform draw (up to 1000 tries).
Mat default_starts(const RegionConstraint& region, Rng& rng);

/// The rows of every matrix, one after another (all have `cols` columns; empty ones allowed).
Mat stack_rows(std::initializer_list<const Mat*> parts, Index cols);

/// Keeps the better of two results (the current one on ties), summing the evaluations.
void keep_better(OptimizeResult& best, OptimizeResult candidate);

}  // namespace varbo::nlopt_plugin
