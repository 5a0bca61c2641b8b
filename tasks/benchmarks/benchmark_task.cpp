#include "benchmark_task.hpp"

#include <fmt/format.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "varbo/math.hpp"

namespace varbo::tasks {

BenchmarkTask::BenchmarkTask(const BenchmarkSpec& spec, Index dim, Box box, double noise_std)
    : spec_(spec), dim_(dim), box_(std::move(box)), noise_std_(noise_std) {
  if (box_.dim() != dim_ || box_.upper.size() != dim_)
    throw std::invalid_argument("BenchmarkTask: box dimension differs from dim");
  if (spec_.fixed_dim > 0 && dim_ != spec_.fixed_dim)
    throw std::invalid_argument(spec_.name + " is defined only for d = " + std::to_string(spec_.fixed_dim));
}

Domain BenchmarkTask::domain() const {
  Domain d;
  d.box = box_;
  for (Index i = 0; i < dim_; ++i) d.names.push_back(fmt::format("x{}", i + 1));  // (not "x" + to_string: GCC 12 -Wrestrict false positive)
  return d;
}

Evaluation BenchmarkTask::evaluate(const Vec& theta, Rng& rng) {
  Evaluation e;
  if (theta.size() != dim_) {
    e.ok = false;
    e.error = spec_.name + ": expected " + std::to_string(dim_) + " parameters, got " + std::to_string(theta.size());
    return e;
  }
  if (failure_region_ && failure_region_->contains(to_unit(theta, box_))) {
    e.ok = false;
    e.error = spec_.name + ": θ in the failure region (" + failure_region_->describe() + ")";
    return e;
  }
  e.cost = spec_.f(theta);
  // The noiseless value goes with the trial, so simple regret is measured on f, not on a lucky noisy draw.
  e.noiseless_cost = e.cost;
  // Draw only when noisy, so a noiseless task leaves the stream untouched.
  if (noise_std_ > 0) e.cost += noise_std_ * rng.normal();
  if (!std::isfinite(e.cost)) {
    e.ok = false;
    e.error = spec_.name + ": non-finite value";
  }
  return e;
}

std::optional<Optimum> BenchmarkTask::optimum() const {
  Optimum o;
  o.cost = spec_.min_value(dim_);
  for (const Vec& x : spec_.argmins(dim_))
    if (box_.contains(x, 1e-12)) o.thetas.push_back(x);
  if (o.thetas.empty()) return std::nullopt;
  return o;
}

}  // namespace varbo::tasks
