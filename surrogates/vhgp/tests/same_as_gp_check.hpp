// Shared by the vhgp tests: a vhgp whose constant-noise member is selected predicts as the gp it nests.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "varbo/surrogate.hpp"
#include "varbo_test.hpp"

namespace varbo::vhgp {

// Mean, latent variance, log-noise mean (and its variance 0), their x-gradients and σ_f², equal to 1e-12 relative.
inline void check_same_predictions(const Surrogate& v, const Surrogate& g, const std::vector<Vec>& probes) {
  const auto close = [](double a, double b) { return std::abs(a - b) <= 1e-12 * std::max(1.0, std::abs(b)); };
  for (const Vec& p : probes) {
    const Prediction pv = v.predict(p, true), pg = g.predict(p, true);
    CHECK(close(pv.mean, pg.mean));
    CHECK(close(pv.latent_var, pg.latent_var));
    CHECK(close(pv.log_noise_mean, pg.log_noise_mean));
    CHECK(pv.log_noise_var == 0);
    CHECK((pv.d_mean - pg.d_mean).norm() <= 1e-12 * std::max(1.0, pg.d_mean.norm()));
    CHECK((pv.d_latent_var - pg.d_latent_var).norm() <= 1e-12 * std::max(1.0, pg.d_latent_var.norm()));
  }
  CHECK(close(v.signal_variance(), g.signal_variance()));
}

}  // namespace varbo::vhgp
