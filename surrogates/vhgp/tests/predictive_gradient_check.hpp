// Shared by the vhgp tests: the predictive's x-gradients against central finite differences.
#pragma once

#include "varbo/function.hpp"
#include "varbo_test.hpp"
#include "vhgp_surrogate.hpp"

namespace varbo::vhgp {

// Each component of the conditioned surrogate's predictive (mean, latent variance, log-noise mean and variance)
// as a function of x, checked at `points` uniform inputs of the unit box: relative error < 1e-6, steps of 1e-6.
inline void check_predictive_x_gradients(const VhgpSurrogate& s, Index dim, Rng& rng, int points = 5) {
  for (int t = 0; t < points; ++t) {
    const Vec x = rng.uniform_vec(dim);
    REQUIRE(s.predict(x, true).has_gradient());
    for (int k = 0; k < 4; ++k) {
      FunctionRef fn(dim, [&s, k](const Vec& z, Vec* g) {
        const Prediction q = s.predict(z, g != nullptr);
        const double values[] = {q.mean, q.latent_var, q.log_noise_mean, q.log_noise_var};
        if (g) *g = k == 0 ? q.d_mean : k == 1 ? q.d_latent_var : k == 2 ? q.d_log_noise_mean : q.d_log_noise_var;
        return values[k];
      });
      const GradientCheck c = check_gradient(fn, x, 1e-6, 1e-6);
      CAPTURE(k);
      CAPTURE(c.max_abs_error);
      CHECK(c.max_rel_error < 1e-6);
    }
  }
}

}  // namespace varbo::vhgp
