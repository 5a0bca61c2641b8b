#pragma once
// CMA-ES (Hansen, "The CMA Evolution Strategy: A Tutorial", 2016) as an ask/tell Algorithm in the unit cube,
// with the tutorial's default parameters (Table 1).
//
// Bounds: candidates are drawn unclipped from N(m, σ²C); the point handed out (and evaluated) is the candidate
// clipped to [0, 1]^d, and its ranking cost is cost + penalty·range·‖x − clip(x)‖², range = the spread of the
// generation's finite costs (so the penalty is in cost units whatever the task's scale). The update uses the
// unclipped candidates, so the distribution is pushed back inside smoothly (Hansen's tutorial, section B.3).
#include <optional>
#include <vector>

#include "varbo/search_space.hpp"
#include "varbo/algorithm.hpp"
#include "varbo/state.hpp"

namespace varbo {

struct CmaEsOptions {
  double sigma0 = 0.3;
  std::optional<Vec> x0;    ///< unit cube; default: the centre
  Index population = 0;     ///< λ; 0 = 4 + floor(3 ln d)
  double penalty = 10.0;    ///< boundary penalty factor (× the generation's cost range per unit distance²)
  std::uint64_t seed = 0;
  /// Recommend the distribution mean m (clipped to the box) instead of the best observed candidate: under
  /// noise the best observed cost is a lucky draw, while m averages the μ best of each generation.
  bool recommend_mean = false;
  /// Typed parameters (docs/search_space.md): each candidate is handed out at its admissible point (integers
  /// rounded, categories by argmax, constraints repaired), while the distribution is updated with the unrounded
  /// sample, as in CMA-ES with rounding at evaluation; the boundary penalty is on the clipping distance only.
  SharedSpace space;
};

class CmaEs final : public Algorithm, public AlgorithmState, public SpaceAware {
 public:
  CmaEs(Index dim, CmaEsOptions options);
  /// Typed parameters (CmaEsOptions::space), before the first ask().
  void set_search_space(SharedSpace space) override;
  /// The next q candidates of the current generation; when all λ have been handed out and their results are
  /// still pending, further candidates of the same distribution are drawn (they are used if told first).
  std::vector<Suggestion> ask(Index q = 1) override;
  /// Matches observations to pending candidates by x; the distribution is updated as soon as λ results of the
  /// current generation have arrived. Failed observations (ok = false) get the worst cost seen so far.
  void tell(const std::vector<Observation>& observations) override;
  /// Candidates of the current generation pending elsewhere (another worker's suggest) count as handed out, so the
  /// next ask gives the next candidate. Before, every concurrent `varbo suggest` / worker got the same θ.
  void set_pending(const std::vector<Vec>& pending) override;
  std::optional<Vec> recommendation() const override;
  /// Exact snapshot (cma_es_state.cpp): the distribution, its paths and the current generation.
  std::optional<std::string> save_state() const override;
  void restore_state(const std::string& state, const std::vector<Observation>& history) override;

  Index lambda() const { return lambda_; }
  Index generation() const { return generation_; }
  double sigma() const { return sigma_; }
  const Vec& mean() const { return m_; }
  const Mat& covariance() const { return C_; }

 private:
  struct Candidate {
    Vec z;        ///< unclipped
    Vec x;        ///< clipped, handed out
    bool asked = false;
    bool told = false;
    double cost = 0;
  };
  void new_generation();
  void draw_candidate();
  std::vector<Vec> pending_elsewhere_;  ///< pending points of no known candidate (set_pending)
  void update();

  Index d_;
  CmaEsOptions o_;
  Rng rng_;
  // Strategy parameters (Hansen 2016, Table 1).
  Index lambda_, mu_;
  Vec w_;
  double mueff_, cc_, cs_, c1_, cmu_, damps_, chi_n_;
  // State.
  Vec m_, pc_, ps_;
  Mat C_, B_;
  Vec D_;
  double sigma_;
  Index generation_ = 0;
  Index draws_ = 0;
  std::vector<Candidate> pop_;
  Index told_count_ = 0;
  double worst_ = -std::numeric_limits<double>::infinity();
  double best_cost_ = std::numeric_limits<double>::infinity();
  Vec best_x_;
};

}  // namespace varbo
