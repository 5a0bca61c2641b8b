#include "gp_sample.hpp"

#include <fmt/format.h>
#include <nlopt.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "varbo/errors.hpp"
#include "varbo/log.hpp"

namespace varbo::tasks {

double matern52(double r, double ell) {
  const double a = std::sqrt(5.0) * r / ell;
  return (1 + a + a * a / 3) * std::exp(-a);
}

double matern52_dr(double r, double ell) {
  // d/dr (1 + a + a²/3) e^{−a} with a = √5 r/ℓ: −(a/3)(1 + a) e^{−a} · √5/ℓ
  const double a = std::sqrt(5.0) * r / ell;
  return -(a / 3) * (1 + a) * std::exp(-a) * std::sqrt(5.0) / ell;
}

GpSampleFunction::GpSampleFunction(const GpSampleSettings& s) : ell_(s.lengthscale), signal_var_(s.signal_var) {
  if (s.dim < 1) throw ConfigError("gp_sample: dim must be at least 1");
  if (s.features < 1) throw ConfigError("gp_sample: features must be at least 1");
  Rng rng(mix_seed(s.seed, 0x9b5a));
  const Index M = s.features, d = s.dim;
  // Spectral density of Matérn-ν (ν = 5/2) is a multivariate Student-t with 2ν degrees of freedom:
  // ω = z/ℓ · sqrt(2ν/u), z ~ N(0, I), u ~ χ²(2ν)   (Rasmussen & Williams 2006, eq. 4.15).
  std::chi_squared_distribution<double> chi2(5.0);
  omega_.resize(M, d);
  phase_.resize(M);
  weight_.resize(M);
  for (Index j = 0; j < M; ++j) {
    const Vec z = rng.normal_vec(d);
    const double u = chi2(rng.engine());
    omega_.row(j) = (z * std::sqrt(5.0 / std::max(u, 1e-300)) / ell_).transpose();
    phase_(j) = rng.uniform(0, 2 * std::numbers::pi);
    weight_(j) = rng.normal();
  }
  scale_ = std::sqrt(2 * signal_var_ / static_cast<double>(M));
  correction_ = (s.center_value - prior_value(Vec::Zero(d))) / signal_var_;
}

double GpSampleFunction::prior_value(const Vec& theta) const {
  const Vec arg = omega_ * theta + phase_;
  return scale_ * weight_.dot(arg.array().cos().matrix());
}

double GpSampleFunction::value(const Vec& theta, Vec* grad) const {
  const Vec arg = omega_ * theta + phase_;
  double f = scale_ * weight_.dot(arg.array().cos().matrix());
  const double r = theta.norm();
  // Matheron's rule with one noise-free observation at 0: f + k(θ,0) k(0,0)⁻¹ (y0 − f(0)).
  f += signal_var_ * matern52(r, ell_) * correction_;
  if (grad) {
    *grad = -scale_ * omega_.transpose() * (weight_.array() * arg.array().sin()).matrix();
    if (r > 0) *grad += signal_var_ * correction_ * matern52_dr(r, ell_) / r * theta;
  }
  return f;
}

namespace {
struct PolishData {
  const GpSampleFunction* f;
};
double negated(const std::vector<double>& x, std::vector<double>& g, void* data) {
  const auto* p = static_cast<PolishData*>(data);
  const Vec t = Eigen::Map<const Vec>(x.data(), static_cast<Index>(x.size()));
  Vec gr;
  const double v = p->f->value(t, g.empty() ? nullptr : &gr);
  if (!g.empty())
    for (std::size_t i = 0; i < g.size(); ++i) g[i] = -gr(static_cast<Index>(i));
  return -v;
}
}  // namespace

GpSampleTask::GpSampleTask(const GpSampleSettings& s) : s_(s), f_(s) {
  const Index d = s.dim;
  // Dense search: uniform random points (own stream of the seed) plus the centre, then L-BFGS polish (NLopt)
  // of the best 10 inside [−1, 1]^d. The result is the recorded optimum (maximum of f, minimum of the cost).
  Rng rng(mix_seed(s.seed, 0x0b71));
  const Index n = s.search_points > 0 ? s.search_points : 20000 * d;
  std::vector<std::pair<double, Vec>> best;
  const std::size_t keep = 10;
  auto consider = [&](const Vec& x) {
    const double v = f_.value(x);
    if (best.size() < keep || v > best.back().first) {
      best.emplace_back(v, x);
      std::sort(best.begin(), best.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
      if (best.size() > keep) best.pop_back();
    }
  };
  consider(Vec::Zero(d));
  for (Index i = 0; i < n; ++i) consider((2 * rng.uniform_vec(d).array() - 1).matrix());
  double fbest = -INFINITY;
  Vec xbest = best.front().second;
  for (const auto& [v0, x0] : best) {
    nlopt::opt opt(nlopt::LD_LBFGS, static_cast<unsigned>(d));
    opt.set_lower_bounds(std::vector<double>(static_cast<std::size_t>(d), -1.0));
    opt.set_upper_bounds(std::vector<double>(static_cast<std::size_t>(d), 1.0));
    PolishData pd{&f_};
    opt.set_min_objective(negated, &pd);
    opt.set_xtol_abs(1e-10);
    opt.set_ftol_rel(1e-14);
    opt.set_maxeval(2000);
    std::vector<double> x(x0.data(), x0.data() + d);
    double fx = -v0;
    try {
      opt.optimize(x, fx);
    } catch (const std::exception& e) {
      log_debug("gp_sample: polish stopped: {}", e.what());
    }
    const Vec xv = Eigen::Map<const Vec>(x.data(), d).cwiseMax(-1.0).cwiseMin(1.0);
    const double v = f_.value(xv);
    if (v > fbest) fbest = v, xbest = xv;
    if (v0 > fbest) fbest = v0, xbest = x0;
  }
  optimum_.cost = -fbest;
  optimum_.thetas = {xbest};
  // Initial point: at distance start_distance from the optimum in a random direction that stays in the domain
  // (paper, section 5.1 and Fig. 3 caption).
  Rng irng(mix_seed(s.seed, 0x1417));
  initial_ = xbest;
  for (int attempt = 0; attempt < 1000; ++attempt) {
    Vec u = irng.normal_vec(d);
    const Vec cand = xbest + s.start_distance * u / std::max(u.norm(), 1e-300);
    if ((cand.array().abs() <= 1.0).all()) {
      initial_ = cand;
      break;
    }
    if (attempt == 999) log_warn("gp_sample: no direction keeps the initial point inside the domain; using the optimum");
  }
}

Domain GpSampleTask::domain() const {
  Domain dom;
  dom.box.lower = Vec::Constant(s_.dim, -1.0);
  dom.box.upper = Vec::Constant(s_.dim, 1.0);
  for (Index i = 0; i < s_.dim; ++i) dom.names.push_back(fmt::format("x{}", i + 1));
  return dom;
}

Evaluation GpSampleTask::evaluate(const Vec& theta, Rng& rng) {
  if (theta.size() != s_.dim)
    throw InputError(fmt::format("gp_sample: theta has {} values, expected {}", theta.size(), s_.dim));
  Evaluation e;
  e.noiseless_cost = -f_.value(theta);
  e.cost = e.noiseless_cost + s_.noise_std * rng.normal();
  return e;
}

}  // namespace varbo::tasks
