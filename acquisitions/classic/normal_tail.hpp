#pragma once
// The normal "expected positive part" τ(u) = E[max(u − Z, 0)] = u·Φ(u) + φ(u), Z ~ N(0, 1): the core of EI.
// Evaluated without the catastrophic cancellation of the direct formula in the lower tail.

namespace varbo::acq {

/// τ(u) = u·Φ(u) + φ(u) ≥ 0, accurate to about 1e-15 relative for every finite u (0 for u = −∞, u for +∞).
double normal_expected_positive_part(double u);

}  // namespace varbo::acq
