// The recommendation rules of `bo` (issue 10): the recommended θ is chosen on a model that saw every
// observation, by the rule the configuration names, and recommending never changes a trial.
#include <cmath>
#include <limits>

#include "varbo/algorithm.hpp"
#include "varbo/log.hpp"
#include "varbo/optimizer.hpp"
#include "varbo/registry.hpp"
#include "varbo/state.hpp"
#include "recommender.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {

std::unique_ptr<Algorithm> make_bo(const std::string& options, Index dim, Index budget, std::uint64_t seed = 1) {
  BuildContext ctx;
  ctx.dim = dim;
  ctx.budget = budget;
  ctx.seed = seed;
  return test::registry().create<Algorithm>("{type: bo, " + options + "}", ctx);
}

double quadratic(const Vec& x) { return (x.array() - 0.3).square().sum(); }

// Asks and tells `n` trials of f.
void run_trials(Algorithm& a, Index n, double (*f)(const Vec&)) {
  for (Index i = 0; i < n; ++i) {
    const Suggestion s = a.ask(1).front();
    a.tell({Observation{s.x, f(s.x), true, {}}});
  }
}

Index row_of(const Dataset& d, const Vec& x) {
  for (Index i = 0; i < d.size(); ++i)
    if ((d.X.row(i).transpose() - x).norm() == 0) return i;
  return -1;
}

}  // namespace

TEST_CASE("recommendation: a bad last observation is not recommended (the model saw it)") {
  set_log_level(LogLevel::Error);
  // The point the model fitted at the last ask() believes best, then observed as a disaster (a crash
  // costs 100). A recommendation from that stale model keeps recommending it; one from a model
  // conditioned on every observation does not.
  auto a = make_bo("initial_points: 6, surrogate: {type: gp, restarts: 1}", 1, 8);
  run_trials(*a, 6, quadratic);
  a->ask(1);  // fits the model on the 6 observations
  const Surrogate* m = a->model();
  REQUIRE(m != nullptr);
  Vec lowest(1);
  double lowest_mean = std::numeric_limits<double>::infinity();
  for (int i = 0; i <= 1000; ++i) {
    const Vec x = Vec::Constant(1, i / 1000.0);
    const double mu = m->predict(x, false).mean;
    if (mu < lowest_mean) lowest_mean = mu, lowest = x;
  }
  a->tell({Observation{lowest, 100.0, true, {}}});
  const auto rec = a->recommendation();
  REQUIRE(rec.has_value());
  CHECK((*rec - lowest).norm() > 1e-9);
  CHECK(quadratic(*rec) < 0.1);  // one of the good observations
}

TEST_CASE("recommendation: recommending changes no trial") {
  set_log_level(LogLevel::Error);
  for (const std::string rule : {"lowest_mean_evaluated", "lowest_mean_domain", "lowest_bound_evaluated"}) {
    CAPTURE(rule);
    const std::string cfg = "initial_points: 4, recommendation: " + rule + ", surrogate: {type: gp, restarts: 2}";
    auto a = make_bo(cfg, 2, 9, 5), b = make_bo(cfg, 2, 9, 5);
    for (int i = 0; i < 9; ++i) {
      const Suggestion sa = a->ask(1).front(), sb = b->ask(1).front();
      REQUIRE(sa.x == sb.x);
      a->tell({Observation{sa.x, quadratic(sa.x), true, {}}});
      b->tell({Observation{sb.x, quadratic(sb.x), true, {}}});
      (void)a->recommendation();  // only a recommends, after every trial (the final one refits)
    }
  }
}

TEST_CASE("recommendation: best_observed is the lowest observed cost") {
  set_log_level(LogLevel::Error);
  auto a = make_bo("initial_points: 5, recommendation: best_observed", 2, 8);
  Vec best;
  double best_y = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 8; ++i) {
    const Suggestion s = a->ask(1).front();
    // A noisy observation: the lowest observed is not the lowest f.
    const double y = quadratic(s.x) + 0.05 * std::sin(37.0 * i);
    if (y < best_y) best_y = y, best = s.x;
    a->tell({Observation{s.x, y, true, {}}});
  }
  const auto rec = a->recommendation();
  REQUIRE(rec.has_value());
  CHECK(*rec == best);
}

TEST_CASE("recommendation: lowest_bound_evaluated minimizes E + kappa s over the data; kappa = 0 is the mean rule") {
  set_log_level(LogLevel::Error);
  const std::string base = "initial_points: 8, surrogate: {type: gp, restarts: 1, hyperparameters: "
                           "{lengthscale: 0.3, signal_std: 1.0, noise_std: 0.05}}";
  // Fixed hyperparameters: the recommendation model is then an exactly known GP, so the brute-force
  // minimum below is computed on the same numbers by a second path (predict() at every data point).
  auto a = make_bo(base + ", recommendation: lowest_bound_evaluated, recommendation_kappa: 2", 2, 12);
  auto b = make_bo(base + ", recommendation: lowest_mean_evaluated", 2, 12);
  auto c = make_bo(base + ", recommendation: lowest_bound_evaluated, recommendation_kappa: 0", 2, 12);
  Dataset data = Dataset::empty(2);
  Rng noise(3);
  for (int i = 0; i < 10; ++i) {
    const Suggestion s = a->ask(1).front();
    const double y = quadratic(s.x) + 0.05 * noise.normal();
    data.add(s.x, y);
    for (auto* alg : {a.get(), b.get(), c.get()}) alg->tell({Observation{s.x, y, true, {}}});
  }
  // Reference: a GP conditioned on the same data with the same fixed hyperparameters.
  BuildContext ctx;
  ctx.dim = 2;
  auto gp = test::registry().create<Surrogate>(
      "{type: gp, hyperparameters: {lengthscale: 0.3, signal_std: 1.0, noise_std: 0.05}}", ctx);
  REQUIRE(gp->condition(data).ok);
  auto argmin = [&](double kappa) {
    Index best = -1;
    double v = std::numeric_limits<double>::infinity();
    for (Index i = 0; i < data.size(); ++i) {
      const Prediction p = gp->predict(data.X.row(i).transpose(), false);
      if (p.mean + kappa * p.total_std() < v) v = p.mean + kappa * p.total_std(), best = i;
    }
    return best;
  };
  CHECK(row_of(data, *a->recommendation()) == argmin(2.0));
  CHECK(row_of(data, *b->recommendation()) == argmin(0.0));
  CHECK(*c->recommendation() == *b->recommendation());
}

TEST_CASE("recommendation: lowest_mean_domain finds the posterior mean's minimum between the data") {
  set_log_level(LogLevel::Error);
  // Noise-free quadratic with minimum at (0.3, 0.3), sampled only on a coarse design: the posterior mean's
  // minimum lies between the data, closer to the true minimizer than the best evaluated point.
  auto dom = make_bo("initial_points: 12, recommendation: lowest_mean_domain", 2, 12, 7);
  auto at_data = make_bo("initial_points: 12, recommendation: lowest_mean_evaluated", 2, 12, 7);
  for (int i = 0; i < 12; ++i) {
    const Suggestion s = dom->ask(1).front();
    const Suggestion t = at_data->ask(1).front();
    REQUIRE(s.x == t.x);
    dom->tell({Observation{s.x, quadratic(s.x), true, {}}});
    at_data->tell({Observation{t.x, quadratic(t.x), true, {}}});
  }
  const Vec r = *dom->recommendation(), e = *at_data->recommendation();
  CHECK(quadratic(r) <= quadratic(e));
  CHECK(quadratic(r) < 1e-3);  // (the best of 12 LHS points in 2-D is typically ~1e-2 away)
}

namespace {
// A model with scripted means at the data points (by row) and a constant noise std.
class ScriptedModel final : public Surrogate {
 public:
  ScriptedModel(Dataset data, Vec means, double noise_std) : data_(std::move(data)), means_(std::move(means)), sn_(noise_std) {}
  FitReport fit(const Dataset&, Rng&) override { return {}; }
  FitReport condition(const Dataset&) override { return {}; }
  Prediction predict(const Vec& x, bool) const override {
    Prediction p;
    for (Index i = 0; i < data_.size(); ++i)
      if ((data_.X.row(i).transpose() - x).norm() == 0) p.mean = means_(i);
    p.log_noise_mean = 2 * std::log(sn_);
    return p;
  }
  double signal_variance() const override { return 1; }
  Hyperparameters hyperparameters() const override { return {}; }
  void set_hyperparameters(const Hyperparameters&) override {}
  bool ready() const override { return true; }

 private:
  Dataset data_;
  Vec means_;
  double sn_;
};
}  // namespace

TEST_CASE("recommendation: lowest_mean_evaluated breaks ties within a tenth of the noise std by the observed cost") {
  Dataset data = Dataset::empty(1);
  for (double x : {0.1, 0.2, 0.3, 0.4}) data.add(Vec::Constant(1, x), 0.0);
  data.y << 5.0, 1.0 + 2e-9, 1.0, 0.2;  // row 2 is the best of the near-equal pair; row 3 the lowest cost; std(y) 2.1
  // A nearly deterministic cost (noise 1e-4, above 1e-5 std(y)): the means of rows 1 and 2 differ by less than a
  // tenth of the noise and in the wrong order; the tie goes to the lower cost. Row 3's mean is far above: not tied,
  // however low its cost.
  const Vec means = (Vec(4) << 5.0, 1.0 - 3e-6, 1.0, 1.5).finished();
  CHECK(bo::lowest_mean_evaluated(ScriptedModel(data, means, 1e-4), data) == 2);
  // With a mean gap of 2 noise std the model does order them: the lowest mean wins.
  const Vec apart = (Vec(4) << 5.0, 1.0 - 2e-4, 1.0, 1.5).finished();
  CHECK(bo::lowest_mean_evaluated(ScriptedModel(data, apart, 1e-4), data) == 1);
  // Half a noise std is no tie either (the winner's curse of a noisy cost).
  const Vec half = (Vec(4) << 5.0, 1.0 - 5e-5, 1.0, 1.5).finished();
  CHECK(bo::lowest_mean_evaluated(ScriptedModel(data, half, 1e-4), data) == 1);
  // A noisy cost (noise 0.5): only means within 0.05 tie; row 3 (mean 1.5, cost 0.2) is not recommended.
  CHECK(bo::lowest_mean_evaluated(ScriptedModel(data, means, 0.5), data) == 2);
  const Vec lucky = (Vec(4) << 5.0, 1.0, 1.06, 1.5).finished();
  CHECK(bo::lowest_mean_evaluated(ScriptedModel(data, lucky, 0.5), data) == 1);
}

TEST_CASE("recommendation: a model that treats the cost as deterministic recommends the lowest observed cost") {
  Dataset data = Dataset::empty(1);
  for (double x : {0.1, 0.2, 0.3, 0.4}) data.add(Vec::Constant(1, x), 0.0);
  data.y << 5.0, 1.0 + 2e-9, 1.0, 0.2;  // std(y) = 2.1
  // Noise 1e-6 <= 1e-5 std(y): the observations are the costs; means that miss them (misfit, rounding) do not
  // outvote them, whatever the gap.
  const Vec means = (Vec(4) << 5.0, 1.0 - 3e-8, 1.0, 1.5).finished();
  CHECK(bo::lowest_mean_evaluated(ScriptedModel(data, means, 1e-6), data) == 3);
  const Vec apart = (Vec(4) << 5.0, 0.5, 1.0, 1.5).finished();
  CHECK(bo::lowest_mean_evaluated(ScriptedModel(data, apart, 2e-5), data) == 3);
  // Just above the threshold (noise 3e-5 > 1e-5 std(y)): the lowest mean again.
  CHECK(bo::lowest_mean_evaluated(ScriptedModel(data, apart, 3e-5), data) == 1);
}

TEST_CASE("recommendation: a vhgp's final refit continues its fit schedule from the run model (warm_final_refit)") {
  set_log_level(LogLevel::Error);
  // 25 noisy observations of a 1-D cost; the run's model last fitted (fully, N > 20) on the first 24.
  Rng data_rng(3);
  Dataset all = Dataset::empty(1), first = Dataset::empty(1);
  for (Index i = 0; i < 25; ++i) {
    const Vec x = data_rng.uniform_vec(1);
    const double y = std::sin(6.0 * x(0)) + (0.05 + 0.5 * x(0)) * data_rng.normal();
    all.add(x, y);
    if (i < 24) first.add(x, y);
  }
  BuildContext ctx;
  ctx.dim = 1;
  const auto schedule = [](const Surrogate& s) {
    for (const auto& [name, value] : s.state())
      if (name == "last_full_fit_n") return value(0);
    return -1.0;
  };
  const BoxRegion region(Box::unit(1));
  const std::unique_ptr<Optimizer> optimizer = test::registry().create<Optimizer>("ceres_lbfgs", ctx);
  for (const bool warm : {true, false}) {
    CAPTURE(warm);
    const std::string yaml = std::string("{type: vhgp, restarts: 3, warm_final_refit: ") + (warm ? "true" : "false") + "}";
    const std::unique_ptr<Surrogate> run_model = test::registry().create<Surrogate>(yaml, ctx);
    Rng fit_rng(5);
    REQUIRE(run_model->fit(first, fit_rng).ok);
    bo::Recommender rec(bo::RecommendationRule::LowestMeanEvaluated, 0.0,
                        test::registry().create<Surrogate>(yaml, ctx));
    Rng rng(9);
    (void)rec.recommend(run_model.get(), all, Mat(0, 1), region, *optimizer, rng, true);
    REQUIRE(rec.model() != nullptr);
    if (!warm) {
      // A fresh model's full fit: no counter reported, the recommendation model refitted from scratch.
      CHECK(schedule(*run_model) == -1.0);
      CHECK(schedule(*rec.model()) == -1.0);
      continue;
    }
    // 25 < 1.25 × 24: the final refit is warm-only, as one more fit of the run's model would be — the same
    // model, bit for bit, as restoring the run model's snapshot and fitting it with the same random stream.
    CHECK(schedule(*run_model) == 24.0);
    CHECK(schedule(*rec.model()) == 24.0);
    const std::unique_ptr<Surrogate> continued = test::registry().create<Surrogate>(yaml, ctx);
    state_of(continued.get())->restore_state(state_of(run_model.get())->save_state());
    Rng same(9);
    REQUIRE(continued->fit(all, same).ok);
    const Hyperparameters a = rec.model()->hyperparameters(), b = continued->hyperparameters();
    REQUIRE(a.size() == b.size());
    for (std::size_t i = 0; i < a.size(); ++i) CHECK(a[i].value == b[i].value);
    for (Index i = 0; i < all.size(); ++i)
      CHECK(rec.model()->predict(all.X.row(i).transpose(), false).mean ==
            continued->predict(all.X.row(i).transpose(), false).mean);
  }
}

TEST_CASE("recommendation: a model with a non-finite mean at the data recommends the lowest observed cost") {
  // `mean < NaN` never holds: trial 0 was recommended whatever its cost (red team, session 26).
  Dataset data = Dataset::empty(1);
  for (double x : {0.1, 0.2, 0.3, 0.4}) data.add(Vec::Constant(1, x), 0.0);
  data.y << 5.0, 1.0, 0.2, 3.0;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  CHECK(bo::lowest_mean_evaluated(ScriptedModel(data, (Vec(4) << nan, nan, nan, nan).finished(), 0.1), data) == 2);
  CHECK(bo::lowest_mean_evaluated(ScriptedModel(data, (Vec(4) << 0.0, 1.0, nan, 3.0).finished(), 0.1), data) == 2);
}

TEST_CASE("recommendation: lowest_mean_domain keeps away from failed trials") {
  set_log_level(LogLevel::Error);
  // A cost falling towards x = 1, where every trial beyond 0.7 fails: the model's mean keeps falling past the last
  // success, and its minimum over the box lay between the failures (red team, session 26: 0.81). The
  // recommendation stays within the successes' side of AwayFromFailures (nearest failure ≥ 2× as far as the
  // nearest success).
  const auto cost = [](const Vec& x) { return 1.0 - x(0); };
  for (const std::string rule : {"lowest_mean_domain", "lowest_mean_evaluated"}) {
    CAPTURE(rule);
    auto a = make_bo("initial_points: 8, recommendation: " + rule + ", surrogate: {type: gp, restarts: 2}", 1, 8, 3);
    Mat failed(0, 1);
    double last_success = 0;
    std::vector<double> successes;
    for (int i = 0; i < 8; ++i) {
      const Suggestion s = a->ask(1).front();
      const bool ok = s.x(0) <= 0.7;
      a->tell({Observation{s.x, ok ? cost(s.x) : std::numeric_limits<double>::quiet_NaN(), ok, {}}});
      if (ok) last_success = std::max(last_success, s.x(0)), successes.push_back(s.x(0));
      else failed.conservativeResize(failed.rows() + 1, 1), failed(failed.rows() - 1, 0) = s.x(0);
    }
    REQUIRE(failed.rows() > 0);
    REQUIRE(successes.size() >= 2);
    const Vec r = *a->recommendation();
    double nearest_success = 1e9, nearest_failure = 1e9;
    for (double s : successes) nearest_success = std::min(nearest_success, std::abs(r(0) - s));
    for (Index i = 0; i < failed.rows(); ++i) nearest_failure = std::min(nearest_failure, std::abs(r(0) - failed(i, 0)));
    CHECK(nearest_failure >= 2.0 * nearest_success - 1e-9);
    CHECK(r(0) <= 0.7 + 1e-9);
  }
}

TEST_CASE("recommendation: lowest_mean_domain stays where success is likely, not only away from the failed trials") {
  set_log_level(LogLevel::Error);
  // 2-D: the cost falls towards x1 = 1 and every trial with x1 > 0.7 fails. The few failed trials sit at other x2
  // than the best successes, so the distance rule alone allowed the minimum on its edge past the boundary (red team,
  // session 27: 0.708 recommended, a fall). With the failure model's classifier, fitted on every trial, the
  // recommendation is at least as likely to succeed as the evaluated point it replaces (up to 0.8).
  const auto cost = [](const Vec& x) { return 1.0 - x(0) + 0.3 * (x(1) - 0.5) * (x(1) - 0.5); };
  // Before (distance rule only), seeds 1–6: all six past 0.7, by 0.001–0.059 (seed 2: 0.7356, next to a failed
  // trial at 0.735). With the classifier: two of six past it, by at most 0.0038.
  // Without failure_model.global_probe (session 36), which is not what this tests: with it, seed 3's fresh start
  // probes (1.0, 0.5), where the model of every trial is confident the cost falls on, fails there, and the fresh
  // design's trials leave the last success at x1 = 0.692; the rule then recommends 0.708 (P(success) judged as at
  // the evaluated point it replaces), 0.016 past that success and 0.008 past the boundary. Nor with the same probe
  // during an attempt (probe_every, session 41): with it seed 5 recommends 0.714.
  int recommended_past = 0, runs = 0;
  for (std::uint64_t seed : {1, 2, 3, 4, 5, 6}) {
    CAPTURE(seed);
    auto a = make_bo("initial_points: 8, recommendation: lowest_mean_domain, surrogate: {type: gp, restarts: 2}, "
                     "failure_model: {global_probe: false, probe_every: 0}",
                     2, 25, seed);
    int failures = 0;
    for (int i = 0; i < 25; ++i) {
      const Suggestion s = a->ask(1).front();
      const bool ok = s.x(0) <= 0.7;
      failures += !ok;
      a->tell({Observation{s.x, ok ? cost(s.x) : std::numeric_limits<double>::quiet_NaN(), ok, {}}});
    }
    if (failures == 0) continue;
    ++runs;
    const Vec r = *a->recommendation();
    recommended_past += r(0) > 0.7;
    // Beyond the last successes the data cannot place the boundary (they end 0.0004–0.005 short of it): a
    // recommendation may sit that close past it, not further.
    CHECK(r(0) <= 0.705);
  }
  REQUIRE(runs >= 4);
  CHECK(recommended_past <= runs / 2);
}

TEST_CASE("recommendation: no evaluated-point rule names a θ where a trial also failed") {
  set_log_level(LogLevel::Error);
  // A gain observed once at the lowest cost and failed three times at the very same θ (replicates, or
  // `varbo fail --theta`) was recommended by every evaluated-point rule (red team, session 31).
  for (const std::string rule : {"lowest_mean_evaluated", "lowest_bound_evaluated", "best_observed",
                                 "lowest_mean_domain"}) {
    CAPTURE(rule);
    auto a = make_bo("initial_points: 6, recommendation: " + rule + ", surrogate: {type: gp, restarts: 2}", 2, 12, 5);
    Vec risky;
    for (int i = 0; i < 6; ++i) {
      const Suggestion s = a->ask(1).front();
      a->tell({Observation{s.x, quadratic(s.x), true, {}}});
    }
    risky = Vec::Constant(2, 0.3);  // the optimum of `quadratic`: its one success is the lowest cost
    a->tell({Observation{risky, quadratic(risky), true, {}}});
    for (int k = 0; k < 3; ++k) a->tell({Observation{risky, std::numeric_limits<double>::quiet_NaN(), false, {}}});
    const auto rec = a->recommendation();
    REQUIRE(rec.has_value());
    CHECK((*rec - risky).cwiseAbs().maxCoeff() > 1e-6);
  }
}

namespace {
// A noise-free model whose mean 1 − x falls towards x = 1 everywhere, with its gradient.
class FallingMean final : public Surrogate {
 public:
  FitReport fit(const Dataset&, Rng&) override { return {}; }
  FitReport condition(const Dataset&) override { return {}; }
  Prediction predict(const Vec& x, bool grad) const override {
    Prediction p;
    p.mean = 1.0 - x(0);
    if (grad) {
      p.d_mean = Vec::Constant(1, -1.0);
      p.d_latent_var = p.d_log_noise_mean = p.d_log_noise_var = Vec::Zero(1);
    }
    return p;
  }
  double signal_variance() const override { return 1; }
  Hyperparameters hyperparameters() const override { return {}; }
  void set_hyperparameters(const Hyperparameters&) override {}
  bool ready() const override { return true; }
};
}  // namespace

TEST_CASE("recommendation: lowest_mean_domain asks for the incumbent's P(success) only up to the cap") {
  set_log_level(LogLevel::Error);
  // Successes at x = 0.1 … 0.6, one failure at 0.95, a mean falling towards the failure, and P(success) 0.99 up to
  // the last success, then falling by 3.3 per unit. The incumbent (x = 0.6) has P = 0.99, above the cap 0.8: the
  // recommendation may go as far as P = 0.8, at x = 0.6 + 0.19 / 3.3 = 0.6576 (AwayFromFailures allows up to
  // 0.7167). Asking for the incumbent's own 0.99 (max instead of min; a surviving mutant of session 31) keeps it at
  // 0.6. With the cap at 0.7 the contour moves to 0.6 + 0.29 / 3.3 = 0.6879.
  Dataset data = Dataset::empty(1);
  for (double x : {0.1, 0.2, 0.3, 0.4, 0.5, 0.6}) data.add(Vec::Constant(1, x), 1.0 - x);
  const Mat failed = Mat::Constant(1, 1, 0.95);
  BuildContext ctx;
  ctx.dim = 1;
  const BoxRegion region(Box::unit(1));
  const std::unique_ptr<Optimizer> optimizer = test::registry().create<Optimizer>("multistart", ctx);
  for (const double cap : {0.8, 0.7}) {
    CAPTURE(cap);
    bo::SuccessOdds odds;
    odds.cap = cap;
    odds.probability = [](const Vec& x, Vec* grad) {
      const bool falling = x(0) > 0.6;
      if (grad) *grad = Vec::Constant(1, falling ? -3.3 : 0.0);
      return falling ? 0.99 - 3.3 * (x(0) - 0.6) : 0.99;
    };
    bo::Recommender rec(bo::RecommendationRule::LowestMeanDomain, 0.0, std::make_unique<FallingMean>());
    Rng rng(4);
    const Vec r = rec.recommend(nullptr, data, failed, region, *optimizer, rng, true, odds);
    const double contour = 0.6 + (0.99 - cap) / 3.3;
    CHECK(std::abs(r(0) - contour) <= 2e-3);  // the optimizer's constraint tolerance
    CHECK(odds.probability(r, nullptr) >= cap - 1e-6);
  }
}
