#include "cma_es.hpp"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "varbo/errors.hpp"
#include "varbo/log.hpp"

namespace varbo {

CmaEs::CmaEs(Index dim, CmaEsOptions options) : d_(dim), o_(std::move(options)), rng_(o_.seed) {
  if (d_ <= 0) throw ConfigError("cma_es: the problem dimension must be positive");
  if (!(o_.sigma0 > 0)) throw ConfigError("cma_es: sigma0 must be positive");
  const double n = static_cast<double>(d_);
  // Hansen 2016, Table 1 (default parameters).
  lambda_ = o_.population > 0 ? o_.population : 4 + static_cast<Index>(std::floor(3.0 * std::log(n)));
  lambda_ = std::max<Index>(lambda_, 2);
  const double mu_prime = 0.5 * static_cast<double>(lambda_);
  mu_ = static_cast<Index>(std::floor(mu_prime));
  w_.resize(mu_);
  for (Index i = 0; i < mu_; ++i) w_[i] = std::log(mu_prime + 0.5) - std::log(static_cast<double>(i + 1));
  w_ /= w_.sum();
  mueff_ = 1.0 / w_.squaredNorm();
  cc_ = (4.0 + mueff_ / n) / (n + 4.0 + 2.0 * mueff_ / n);
  cs_ = (mueff_ + 2.0) / (n + mueff_ + 5.0);
  c1_ = 2.0 / ((n + 1.3) * (n + 1.3) + mueff_);
  cmu_ = std::min(1.0 - c1_, 2.0 * (mueff_ - 2.0 + 1.0 / mueff_) / ((n + 2.0) * (n + 2.0) + mueff_));
  damps_ = 1.0 + 2.0 * std::max(0.0, std::sqrt((mueff_ - 1.0) / (n + 1.0)) - 1.0) + cs_;
  chi_n_ = std::sqrt(n) * (1.0 - 1.0 / (4.0 * n) + 1.0 / (21.0 * n * n));  // E‖N(0, I)‖

  m_ = o_.x0 ? *o_.x0 : Vec::Constant(d_, 0.5);
  if (m_.size() != d_) throw ConfigError(fmt::format("cma_es: x0 has {} entries, the problem {}", m_.size(), d_));
  if (!Box::unit(d_).contains(m_)) throw ConfigError("cma_es: x0 must lie in the unit cube");
  sigma_ = o_.sigma0;
  pc_ = Vec::Zero(d_);
  ps_ = Vec::Zero(d_);
  C_ = Mat::Identity(d_, d_);
  B_ = Mat::Identity(d_, d_);
  D_ = Vec::Ones(d_);
  best_x_ = m_;
  new_generation();
}

void CmaEs::draw_candidate() {
  // Stream per (generation, draw): the sequence of candidates does not depend on how ask() is batched.
  Rng r = rng_.stream(static_cast<std::uint64_t>(generation_), static_cast<std::uint64_t>(draws_++));
  const Vec z = m_ + sigma_ * (B_ * D_.cwiseProduct(r.normal_vec(d_)));
  const Vec clipped = z.cwiseMax(0.0).cwiseMin(1.0);
  pop_.push_back(Candidate{z, o_.space ? o_.space->admissible(clipped) : clipped, false, false, 0.0});
}

void CmaEs::set_search_space(SharedSpace space) {
  o_.space = std::move(space);
  for (auto& c : pop_)
    if (!c.asked) c.x = o_.space ? o_.space->admissible(c.z.cwiseMax(0.0).cwiseMin(1.0)) : Vec(c.z.cwiseMax(0.0).cwiseMin(1.0));
}

void CmaEs::new_generation() {
  pop_.clear();
  draws_ = 0;
  told_count_ = 0;
  for (Index k = 0; k < lambda_; ++k) draw_candidate();
}

std::vector<Suggestion> CmaEs::ask(Index q) {
  std::vector<Suggestion> out;
  for (Index k = 0; k < q; ++k) {
    // Nor a told one: a result of a candidate this process never asked (another process's, or one the replay
    // matched after an earlier trial was abandoned) was handed out again (red team, session 23).
    auto it = std::find_if(pop_.begin(), pop_.end(), [](const Candidate& c) { return !c.asked && !c.told; });
    while (it == pop_.end()) {
      draw_candidate();
      it = pop_.end() - 1;
      const auto elsewhere = std::find(pending_elsewhere_.begin(), pending_elsewhere_.end(), it->x);
      if (elsewhere != pending_elsewhere_.end()) {  // handed out by another process already
        it->asked = true;
        pending_elsewhere_.erase(elsewhere);
        it = pop_.end();
      }
    }
    it->asked = true;
    out.push_back(Suggestion{it->x, "cma_es", 0, 0});
  }
  return out;
}

void CmaEs::set_pending(const std::vector<Vec>& pending) {
  pending_elsewhere_.clear();
  for (const Vec& p : pending) {
    bool matched = false;
    for (auto& c : pop_)
      if (!c.told && c.x.size() == p.size() && c.x == p) {
        c.asked = matched = true;
        break;
      }
    // Not in the generation as this process knows it: a candidate drawn beyond λ by the process that asked it,
    // which this process's next draws repeat (the same stream): skipped when drawn (ask).
    if (!matched) pending_elsewhere_.push_back(p);
  }
}

void CmaEs::tell(const std::vector<Observation>& observations) {
  for (const auto& obs : observations) {
    double cost = obs.cost;
    if (obs.ok && std::isfinite(cost)) {
      worst_ = std::max(worst_, cost);
      if (cost < best_cost_) {
        best_cost_ = cost;
        best_x_ = obs.x;
      }
    } else {
      // A failed trial ranks with the worst cost seen (or last, if nothing has succeeded yet).
      cost = std::isfinite(worst_) ? worst_ : std::numeric_limits<double>::max();
    }
    for (auto& c : pop_) {
      // Asked here or by another process (a worker's candidate, told after this process rebuilt the generation).
      if (!c.told && c.x.size() == obs.x.size() && c.x == obs.x) {
        c.told = true;
        c.cost = cost;
        ++told_count_;
        break;
      }
    }
    // Observations of no pending candidate (e.g. an initial design) only update the best and worst costs.
    if (told_count_ >= lambda_) update();
  }
}

void CmaEs::update() {
  std::vector<const Candidate*> told;
  for (const auto& c : pop_)
    if (c.told) told.push_back(&c);
  // Ranking cost with the boundary penalty.
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const auto* c : told)
    if (c->cost < std::numeric_limits<double>::max()) {
      lo = std::min(lo, c->cost);
      hi = std::max(hi, c->cost);
    }
  const double range = std::isfinite(hi - lo) && hi > lo ? hi - lo : 1.0;
  std::vector<double> rank_cost(told.size());
  for (std::size_t i = 0; i < told.size(); ++i)
    rank_cost[i] = told[i]->cost + o_.penalty * range * (told[i]->z - told[i]->z.cwiseMax(0.0).cwiseMin(1.0)).squaredNorm();
  std::vector<std::size_t> order(told.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return rank_cost[a] < rank_cost[b]; });

  // Hansen 2016, eqs. (39)–(47) with positive weights only.
  const Vec m_old = m_;
  Vec yw = Vec::Zero(d_);
  Mat Cmu = Mat::Zero(d_, d_);
  for (Index i = 0; i < mu_; ++i) {
    const Vec y = (told[order[static_cast<std::size_t>(i)]]->z - m_old) / sigma_;
    yw += w_[i] * y;
    Cmu += w_[i] * y * y.transpose();
  }
  m_ = m_old + sigma_ * yw;
  const Vec inv_sqrt_C_yw = B_ * (B_.transpose() * yw).cwiseQuotient(D_);
  ps_ = (1 - cs_) * ps_ + std::sqrt(cs_ * (2 - cs_) * mueff_) * inv_sqrt_C_yw;
  const double ps_norm = ps_.norm();
  const double gen = static_cast<double>(generation_ + 1);
  const bool hsig = ps_norm / std::sqrt(1 - std::pow(1 - cs_, 2 * gen)) <
                    (1.4 + 2.0 / (static_cast<double>(d_) + 1)) * chi_n_;
  pc_ = (1 - cc_) * pc_ + (hsig ? std::sqrt(cc_ * (2 - cc_) * mueff_) : 0.0) * yw;
  const double dh = hsig ? 0.0 : c1_ * cc_ * (2 - cc_);
  C_ = (1 - c1_ - cmu_ + dh) * C_ + c1_ * pc_ * pc_.transpose() + cmu_ * Cmu;
  sigma_ *= std::exp((cs_ / damps_) * (ps_norm / chi_n_ - 1));

  C_ = 0.5 * (C_ + C_.transpose());
  Eigen::SelfAdjointEigenSolver<Mat> eig(C_);
  bool healthy = eig.info() == Eigen::Success && eig.eigenvalues().minCoeff() > 0 && std::isfinite(sigma_) &&
                 m_.allFinite();
  if (healthy) {
    const double cond = eig.eigenvalues().maxCoeff() / eig.eigenvalues().minCoeff();
    healthy = cond < 1e14 && sigma_ * std::sqrt(eig.eigenvalues().maxCoeff()) > 1e-14;
  }
  if (healthy) {
    B_ = eig.eigenvectors();
    D_ = eig.eigenvalues().cwiseSqrt();
  } else {
    // Numerical breakdown (or convergence to machine precision): restart the distribution at the best point.
    log_warn("cma_es: covariance degenerate at generation {}; restarting at the best point with sigma0",
             generation_);
    m_ = best_x_;
    sigma_ = o_.sigma0;
    C_ = Mat::Identity(d_, d_);
    B_ = Mat::Identity(d_, d_);
    D_ = Vec::Ones(d_);
    pc_.setZero();
    ps_.setZero();
  }
  ++generation_;
  new_generation();
}

std::optional<Vec> CmaEs::recommendation() const {
  if (!std::isfinite(best_cost_)) return std::nullopt;
  if (o_.recommend_mean) return Vec(Box::unit(d_).clamp(m_));
  return best_x_;
}

}  // namespace varbo
