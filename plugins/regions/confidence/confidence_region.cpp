#include "confidence_region.hpp"

#include <fmt/format.h>

#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "varbo/errors.hpp"
#include "varbo/log.hpp"

namespace varbo {

ConfidenceRegion::ConfidenceRegion(Index dim, ConfidenceRegionOptions options)
    : options_(options), box_(Box::unit(dim)), data_(Dataset::empty(dim)) {
  if (!(options_.gamma > 0 && options_.gamma < 1))
    throw ConfigError(fmt::format("confidence region: gamma must be in (0, 1), got {}", options_.gamma));
}

double ConfidenceRegion::constraint(const Vec& x, Vec* grad) const {
  if (model_ == nullptr) {
    if (grad) *grad = Vec::Zero(x.size());
    return 1.0;
  }
  const Prediction p = model_->predict(x, grad != nullptr);
  // Fröhlich 2021, eq. (3) squared: γ²σ_f² − σ_n²(θ) ≥ 0, with σ_n² the latent (noise-free) variance.
  const double c = scale_ * options_.gamma * options_.gamma * signal_var_ - p.latent_var;
  if (grad) {
    if (p.d_latent_var.size() == x.size())
      *grad = -p.d_latent_var;
    else
      *grad = Vec::Zero(x.size());
  }
  return std::isfinite(c) ? c : -std::numeric_limits<double>::infinity();
}

bool ConfidenceRegion::probes_feasible(Rng& rng) const {
  const Index d = box_.dim();
  for (Index i = 0; i < data_.size(); ++i) {
    const Vec xi = data_.X.row(i).transpose();
    for (int k = 0; k < options_.probes_per_point; ++k) {
      Vec u = rng.normal_vec(d);
      const double norm = u.norm();
      if (norm <= 0) continue;
      const Vec probe = box_.clamp(xi + (options_.probe_radius / norm) * u);
      if ((probe - xi).norm() <= 0) continue;  // clamped back onto the data point: not a probe
      if (constraint(probe, nullptr) > 0) return true;
    }
  }
  return false;
}

void ConfidenceRegion::update(const Surrogate* model, const Dataset& data, Rng& rng) {
  model_ = model;
  data_ = data;
  scale_ = 1.0;
  widenings_ = 0;
  report_.clear();
  if (model_ == nullptr || data_.size() == 0) return;
  if (data_.dim() != box_.dim())
    throw InputError(fmt::format("confidence region: data have dimension {}, the region {}", data_.dim(),
                                 box_.dim()));
  signal_var_ = model_->signal_variance();
  if (!(signal_var_ > 0) || !std::isfinite(signal_var_)) {
    log_warn("confidence region: the model's signal variance is {}; using 1", signal_var_);
    signal_var_ = 1.0;
  }
  // A fixed stream for the probes, so the region does not depend on how often update() was called.
  Rng probe_rng = rng.stream(0xc0f1de, static_cast<std::uint64_t>(data_.size()));
  // crbo.md (reference implementation): if no point but the data satisfies the constraint, multiply the
  // variance scale by 1.2, up to 50 times. We scale the threshold γ²σ_f² (γ_eff = γ·sqrt(s)) rather than the
  // model's kernel variance, because the region must not modify the surrogate it was given.
  bool feasible = false;
  while (!(feasible = probes_feasible(probe_rng)) && widenings_ < options_.max_widenings) {
    scale_ *= options_.widening_factor;
    ++widenings_;
  }
  if (widenings_ > 0) {
    log_info("confidence region: no point near the data satisfied sigma <= gamma*sigma_f; widened {} times "
             "(variance scale {:.4g}, effective gamma {:.4g})",
             widenings_, scale_, effective_gamma());
    // The loop's own answer: probing again drew new probes, and a region just found non-empty was said to be
    // empty, on every trial (red team, session 30).
    if (!feasible && !std::exchange(said_empty_, true))
      log_warn("confidence region: still empty after {} widenings; samplers fall back to the data points (gamma "
               "{:g} is very small for this model: a larger gamma lets the search leave the data)",
               widenings_, options_.gamma);
  }
  if (options_.report) {
    // Fröhlich 2021, section 4.1: r0, L ≈ max‖∇μ‖ and the worst-case cost of the next trial, for state().
    Rng report_rng = rng.stream(0xca07, static_cast<std::uint64_t>(data_.size()));
    report_ = cautiousness_report(*model_, data_, effective_gamma(), options_.report_kernel, report_rng).text();
  }
}

double ConfidenceRegion::effective_gamma() const { return options_.gamma * std::sqrt(scale_); }

Mat ConfidenceRegion::seeds() const {
  std::vector<Index> inside;
  for (Index i = 0; i < data_.size(); ++i)
    if (contains(data_.X.row(i).transpose())) inside.push_back(i);
  if (inside.empty()) return data_.X;
  Mat S(static_cast<Index>(inside.size()), box_.dim());
  for (std::size_t k = 0; k < inside.size(); ++k) S.row(static_cast<Index>(k)) = data_.X.row(inside[k]);
  return S;
}

std::string ConfidenceRegion::state() const {
  std::string s = fmt::format("gamma {:.3g}, sigma_f^2 {:.4g}, widenings {}, effective gamma {:.4g}",
                              options_.gamma, signal_var_, widenings_, effective_gamma());
  if (!report_.empty()) s += "; " + report_;
  return s;
}

}  // namespace varbo
