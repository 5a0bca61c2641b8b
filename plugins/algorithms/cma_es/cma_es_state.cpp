// Exact snapshot of CMA-ES (varbo/state.hpp): mean, covariance and its eigen-decomposition, step size,
// evolution paths, and the candidates of the current generation with their results. The history is not
// needed: every observation the algorithm has used is in this state.
#include <fmt/format.h>

#include "cma_es.hpp"
#include "varbo/errors.hpp"

namespace varbo {

std::optional<std::string> CmaEs::save_state() const {
  StateMap m;
  m.put("m", m_);
  m.put("pc", pc_);
  m.put("ps", ps_);
  m.put("C", C_);
  m.put("B", B_);
  m.put("D", D_);
  m.put("sigma", sigma_);
  m.put_int("generation", generation_);
  m.put_int("draws", draws_);
  m.put_int("told_count", told_count_);
  m.put("worst", worst_);
  m.put("best_cost", best_cost_);
  m.put("best_x", best_x_);
  std::vector<Vec> z, x;
  Vec asked(static_cast<Index>(pop_.size())), told(static_cast<Index>(pop_.size())), cost(static_cast<Index>(pop_.size()));
  for (std::size_t i = 0; i < pop_.size(); ++i) {
    z.push_back(pop_[i].z);
    x.push_back(pop_[i].x);
    asked[static_cast<Index>(i)] = pop_[i].asked;
    told[static_cast<Index>(i)] = pop_[i].told;
    cost[static_cast<Index>(i)] = pop_[i].cost;
  }
  m.put("pop_z", z);
  m.put("pop_x", x);
  m.put("pop_asked", asked);
  m.put("pop_told", told);
  m.put("pop_cost", cost);
  return m.text();
}

void CmaEs::restore_state(const std::string& text, const std::vector<Observation>&) {
  const StateMap m = StateMap::parse(text, "cma_es state");
  auto check = [&](const Vec& v, const char* key) {
    if (v.size() != d_) throw InputError(fmt::format("cma_es state: '{}' has {} values, expected {}", key, v.size(), d_));
    return v;
  };
  m_ = check(m.vec("m"), "m");
  pc_ = check(m.vec("pc"), "pc");
  ps_ = check(m.vec("ps"), "ps");
  D_ = check(m.vec("D"), "D");
  C_ = m.mat("C");
  B_ = m.mat("B");
  if (C_.rows() != d_ || C_.cols() != d_ || B_.rows() != d_ || B_.cols() != d_)
    throw InputError("cma_es state: covariance of the wrong size");
  sigma_ = m.real("sigma");
  generation_ = static_cast<Index>(m.integer("generation"));
  draws_ = static_cast<Index>(m.integer("draws"));
  told_count_ = static_cast<Index>(m.integer("told_count"));
  worst_ = m.real("worst");
  best_cost_ = m.real("best_cost");
  best_x_ = m.vec("best_x");
  const std::vector<Vec> z = m.rows("pop_z"), x = m.rows("pop_x");
  const Vec asked = m.vec("pop_asked"), told = m.vec("pop_told"), cost = m.vec("pop_cost");
  const auto n = z.size();
  if (x.size() != n || static_cast<std::size_t>(asked.size()) != n || static_cast<std::size_t>(told.size()) != n ||
      static_cast<std::size_t>(cost.size()) != n)
    throw InputError("cma_es state: inconsistent population");
  // Every vector of d coordinates (a saved row of another length was read past its end: SIGSEGV on resume).
  if (best_x_.size() != d_) throw InputError("cma_es state: best_x of the wrong size");
  for (std::size_t i = 0; i < n; ++i)
    if (z[i].size() != d_ || x[i].size() != d_)
      throw InputError(fmt::format("cma_es state: population member {} of the wrong size", i));
  pop_.assign(n, Candidate{});
  for (std::size_t i = 0; i < n; ++i) {
    pop_[i].z = z[i];
    pop_[i].x = x[i];
    pop_[i].asked = asked[static_cast<Index>(i)] != 0;
    pop_[i].told = told[static_cast<Index>(i)] != 0;
    pop_[i].cost = cost[static_cast<Index>(i)];
  }
}

}  // namespace varbo
