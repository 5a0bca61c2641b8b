#pragma once
// What a surrogate and an acquisition hand back is checked at one point per trial before it is used in bulk.
// A third-party model returning a gradient of the wrong length made Eigen (release builds check no sizes) read
// and write past a vector's end inside the built-in acquisitions and optimizers: garbage suggestions or a crash,
// never a message naming the component. One extra prediction per trial costs nothing beside a fit.
#include <string>
#include "varbo/acquisition.hpp"
#include "varbo/region.hpp"
#include "varbo/types.hpp"
#include "varbo/surrogate.hpp"

namespace varbo::bo {

/// Predicts with `model` at x (unit cube, dimension `dim`) with gradients and checks the Prediction's gradients:
/// each of length `dim` (or all empty: a model without gradients).
/// Throws std::runtime_error naming `model_name` and what is wrong; returns the prediction.
Prediction check_surrogate_outputs(const Surrogate& model, const std::string& model_name, const Vec& x, Index dim);

/// What makes a prediction's values unusable (a non-finite mean, a negative or NaN variance), or "" when none.
/// Not an error: costs near the overflow of their squares give such values in a built-in model too, and the
/// acquisition optimizer's fallback survives them; but the user is told, naming the surrogate.
std::string unusable_prediction(const Prediction& p);

/// Evaluates the prepared `acquisition` at x with a gradient and checks its length (`dim`, or empty when the
/// acquisition declares none). Throws std::runtime_error naming `acquisition_name`.
void check_acquisition_outputs(const Acquisition& acquisition, const std::string& acquisition_name, const Vec& x,
                               Index dim);

/// The points a sampler returned for a request of `n` in dimension `dim`: at most n rows (fewer only where
/// `fewer_ok`: a region it finds no point in), `dim` columns, finite, in the unit cube (to 1e-9). A third-party
/// sampler returning 0 rows crashed bo (SIGSEGV), one returning more rows grew the initial design in silence (red
/// team, session 28). Throws std::runtime_error naming `sampler_name`; returns `m`.
Mat check_sampler_outputs(Mat m, const std::string& sampler_name, Index n, Index dim, bool fewer_ok);

/// A region's bounds() after its update: dimension `dim`, finite, lower <= upper, inside the unit cube (to 1e-9);
/// its seeds() (when it has any) `dim` columns, finite, inside the unit cube.
/// A third-party region's bad box was blamed on the surrogate ("gp: predict at a point of dimension 3") or the
/// optimizer, and an inverted one was used in silence (red team, session 28). Throws std::runtime_error naming it.
void check_region_outputs(const RegionConstraint& region, const std::string& region_name, Index dim);

}  // namespace varbo::bo
