#include "noisy_task.hpp"

#include <fmt/format.h>

#include <cmath>
#include <stdexcept>

namespace varbo::tasks::noisy {

NoisyTask::NoisyTask(const NoisyFunctionSpec& spec, Index dim, long instance, Noise noise)
    : spec_(spec), dim_(dim), instance_(instance), noise_(noise) {
  if (spec_.fixed_dim > 0 && dim_ != spec_.fixed_dim)
    throw std::invalid_argument(fmt::format("{} is defined only for d = {}", spec_.name, spec_.fixed_dim));
  if (dim_ < spec_.min_dim)
    throw std::invalid_argument(fmt::format("{} needs d >= {}, got {}", spec_.name, spec_.min_dim, dim_));
  if (instance_ < 1) throw std::invalid_argument(fmt::format("instance must be >= 1, got {}", instance_));
  fn_ = spec_.make(dim_, instance_);
}

Domain NoisyTask::domain() const {
  Domain d;
  d.box = fn_.box;
  for (Index i = 0; i < dim_; ++i) d.names.push_back(fmt::format("x{}", i + 1));
  return d;
}

Evaluation NoisyTask::evaluate(const Vec& theta, Rng& rng) {
  Evaluation e;
  if (theta.size() != dim_) {
    e.ok = false;
    e.error = fmt::format("noisy {}: expected {} parameters, got {}", spec_.name, dim_, theta.size());
    return e;
  }
  const double f = fn_.f(theta);
  e.noiseless_cost = f;
  if (!std::isfinite(f)) {  // cannot happen inside the box; a θ outside it is the caller's mistake
    e.ok = false;
    e.error = fmt::format("noisy {}: non-finite value", spec_.name);
    return e;
  }
  const Vec u = ((theta - fn_.box.lower).array() / fn_.box.width().array()).matrix();
  // Without noise the cost is f itself (f* + (f - f*) may differ from f in the last bit).
  e.cost = noise_.model == NoiseModel::None ? f : fn_.fstar + noise_.apply(f - fn_.fstar, u, rng);
  return e;
}

std::optional<Optimum> NoisyTask::optimum() const {
  Optimum o;
  o.cost = fn_.fstar;
  o.thetas = fn_.argmins;
  return o;
}

std::optional<double> NoisyTask::noiseless_cost(const Vec& theta) const {
  if (theta.size() != dim_) return std::nullopt;
  return fn_.f(theta);
}

std::string NoisyTask::describe() const {
  return fmt::format("{} d={} instance {}, {}", spec_.name, dim_, instance_, noise_.describe());
}

}  // namespace varbo::tasks::noisy
