#include "two_minima.hpp"

#include <cmath>
#include <fmt/format.h>
#include <numbers>

namespace varbo::tasks {

// cos(4πθ) = -1 exactly at θ = 1/4 and 3/4, so both minima are 0.1 by construction (not by tuning).
double two_minima_mean(double theta) { return 0.5 + 0.4 * std::cos(4 * std::numbers::pi * theta); }

// Smooth and increasing, so the log-noise a VHGP learns is smooth; ratio 4 between the two minima.
double two_minima_std(double theta) { return 0.02 + 0.2 * theta * theta; }

Domain TwoMinimaTask::domain() const { return Domain{Box::unit(1), {"theta"}}; }

Evaluation TwoMinimaTask::evaluate(const Vec& theta, Rng& rng) {
  Evaluation e;
  if (theta.size() != 1) {
    e.ok = false;
    e.error = fmt::format("two_minima_1d: expected 1 parameter, got {}", theta.size());
    return e;
  }
  const double t = theta[0];
  e.cost = two_minima_mean(t) + noise_scale_ * two_minima_std(t) * rng.normal();
  return e;
}

std::optional<Optimum> TwoMinimaTask::optimum() const {
  Optimum o;
  o.cost = 0.1;
  o.thetas = {Vec::Constant(1, 0.25), Vec::Constant(1, 0.75)};
  return o;
}

}  // namespace varbo::tasks
