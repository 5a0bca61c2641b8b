#pragma once
// The parameters of a VHGP model in the units the bound is computed in (design note vhgp.md, section 2):
//   [ log Λ_1..log Λ_n ; θ_f ; θ_g ; μ0 ],   θ = the log values of each kernel's parameter table
// (varbo::Kernel::parameters(); [log ℓ_1..log ℓ_D, log σ] for an ARD kernel).
// Λ is kept as log Λ so that Λ > 0 without constraints; μ0 (the prior mean of the log noise variance g) is not
// log-transformed.
#include "varbo/types.hpp"

namespace varbo::vhgp {

struct VhgpParams {
  Vec log_lambda;  ///< n variational parameters (Lázaro-Gredilla & Titsias 2011, Σ⁻¹ = K_g⁻¹ + Λ)
  Vec theta_f;     ///< log-parameters of k_f
  Vec theta_g;     ///< log-parameters of k_g
  double mu0 = 0;  ///< constant prior mean of g

  Index size() const { return log_lambda.size() + theta_f.size() + theta_g.size() + 1; }
  /// Packs into the optimizer's vector, in the order of vhgpr.m.
  Vec pack() const;
  /// Inverse of pack() for n points and kernels with num_f and num_g parameters.
  static VhgpParams unpack(const Vec& v, Index n, Index num_f, Index num_g);
};

/// Gradient of the bound in the same layout as VhgpParams.
struct VhgpGradient {
  Vec log_lambda;  ///< ∂F/∂log Λ
  Vec lambda;      ///< ∂F/∂Λ (reported by the reference files; not used by the optimizer)
  Vec theta_f;
  Vec theta_g;
  double mu0 = 0;
  Vec pack() const;  ///< [∂F/∂log Λ ; ∂F/∂θ_f ; ∂F/∂θ_g ; ∂F/∂μ0]
};

}  // namespace varbo::vhgp
