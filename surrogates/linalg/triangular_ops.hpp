#pragma once
// Dense kernels for a lower-triangular factor that exploit its zeros (LAPACK's trtri and lauum in spirit), shared by
// the gp and vhgp fits.
// Eigen's `L.solve(Identity)` and `rankUpdate(L')` treat the right-hand side / the factor as full and cost
// n³ flops each; the recursive forms below cost n³/3, which is most of the VHGP gradient's saving (surrogates/vhgp/README.md,
// benchmark section).
#include "varbo/types.hpp"

namespace varbo::linalg {

/// L⁻¹ for lower-triangular L (only the lower triangle of L is read; the strictly upper part of the result is 0).
Mat lower_triangular_inverse(const Mat& L);

/// M'M for lower-triangular M (only the lower triangle of M is read); returns the full symmetric matrix.
Mat lower_triangular_gram(const Mat& M);

}  // namespace varbo::linalg
