#include <algorithm>
#include <functional>
#include <cmath>
#include <vector>

#include "hit_and_run.hpp"
#include "varbo/errors.hpp"
#include "varbo/parallel.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {
// A ball of radius r around c inside the unit cube, as a smooth constraint r² − ‖x − c‖² ≥ 0.
class BallRegion final : public RegionConstraint {
 public:
  BallRegion(Vec c, double r, Mat seeds) : box_(Box::unit(c.size())), c_(std::move(c)), r_(r), seeds_(std::move(seeds)) {}
  const Box& bounds() const override { return box_; }
  bool has_constraint() const override { return true; }
  double constraint(const Vec& x, Vec* g) const override {
    if (g) *g = -2.0 * (x - c_);
    return r_ * r_ - (x - c_).squaredNorm();
  }
  Mat seeds() const override { return seeds_; }

 private:
  Box box_;
  Vec c_;
  double r_;
  Mat seeds_;
};

// A sub-box [a, b] of the unit cube expressed as a (non-smooth) constraint, so the sampler must bracket it.
class SubBoxRegion final : public RegionConstraint {
 public:
  SubBoxRegion(Vec a, Vec b) : box_(Box::unit(a.size())), a_(std::move(a)), b_(std::move(b)) {}
  const Box& bounds() const override { return box_; }
  bool has_constraint() const override { return true; }
  double constraint(const Vec& x, Vec* g) const override {
    if (g) *g = Vec::Zero(x.size());
    return std::min((x - a_).minCoeff(), (b_ - x).minCoeff());
  }

 private:
  Box box_;
  Vec a_, b_;
};

// A union of two balls that touch only through a thin neck: non-convex, like CRBO's C_n.
class TwoBallsRegion final : public RegionConstraint {
 public:
  const Box& bounds() const override { return box_; }
  bool has_constraint() const override { return true; }
  double constraint(const Vec& x, Vec* g) const override {
    if (g) *g = Vec::Zero(x.size());
    const double a = 0.04 - (x - Vec::Constant(x.size(), 0.3)).squaredNorm();
    const double b = 0.04 - (x - Vec::Constant(x.size(), 0.65)).squaredNorm();
    return std::max(a, b);
  }
  Mat seeds() const override { return Vec::Constant(2, 0.3).transpose(); }

 private:
  Box box_ = Box::unit(2);
};

// Two-sided Kolmogorov–Smirnov statistic of samples against a continuous CDF.
double ks_statistic(std::vector<double> v, const std::function<double(double)>& cdf) {
  std::sort(v.begin(), v.end());
  const double n = static_cast<double>(v.size());
  double d = 0;
  for (std::size_t i = 0; i < v.size(); ++i) {
    const double F = cdf(v[i]);
    d = std::max({d, static_cast<double>(i + 1) / n - F, F - static_cast<double>(i) / n});
  }
  return d;
}
// Asymptotic critical value of the KS statistic at significance 1% (Kolmogorov distribution, 1.628/sqrt(n)).
double ks_critical_1pct(std::size_t n) { return 1.628 / std::sqrt(static_cast<double>(n)); }

// One sample per chain after a burn-in: the chains are independent, so the samples are i.i.d. (approximately
// from the stationary law after the burn-in), which the KS test assumes.
HitAndRunOptions iid_options(Index n) {
  HitAndRunOptions o;
  o.chains = n;
  o.burn_in = 40;
  return o;
}
}  // namespace

TEST_CASE("hit_and_run: uniform in a ball (KS on the radial CDF (r/R)^d, 1% level)") {
  const Index d = 3;
  const double R = 0.3;
  const Vec c = Vec::Constant(d, 0.5);
  BallRegion ball(c, R, c.transpose());
  HitAndRunSampler sampler(iid_options(1000));
  Rng rng(2024);
  const Mat S = sampler.sample(ball, 1000, rng);
  std::vector<double> radii;
  for (Index i = 0; i < S.rows(); ++i) {
    CHECK(ball.contains(S.row(i).transpose()));
    radii.push_back((S.row(i).transpose() - c).norm());
  }
  const double D = ks_statistic(radii, [&](double r) { return std::pow(std::min(r / R, 1.0), double(d)); });
  MESSAGE("ball d=3, n=1000: KS D = " << D << ", 1% critical value " << ks_critical_1pct(radii.size()));
  CHECK(D < ks_critical_1pct(radii.size()));
  // The same test must reject the chains' starting point distribution (all at the centre), and a direction
  // bias would show in a coordinate: the mean of each coordinate is c within 4 standard errors.
  for (Index j = 0; j < d; ++j) {
    const double se = R / std::sqrt(5.0) / std::sqrt(1000.0);  // sd of one coordinate of a uniform 3-ball: R/√5
    CHECK(std::abs(S.col(j).mean() - 0.5) < 4 * se);
  }
}

TEST_CASE("hit_and_run: uniform in a sub-box (KS per coordinate, 1% level with Bonferroni over 4)") {
  const Vec a = (Vec(4) << 0.1, 0.2, 0.0, 0.5).finished();
  const Vec b = (Vec(4) << 0.4, 0.9, 1.0, 0.6).finished();
  SubBoxRegion sub(a, b);
  // The sub-box is elongated (aspect ratio 10) and hit-and-run mixes in O(aspect² d²) steps: a longer burn-in.
  HitAndRunOptions o = iid_options(800);
  o.burn_in = 400;
  HitAndRunSampler sampler(o);
  Rng rng(7);
  const Mat S = sampler.sample(sub, 800, rng);  // no seeds, centre outside: chains start at a random feasible point
  for (Index i = 0; i < S.rows(); ++i) CHECK(sub.contains(S.row(i).transpose()));
  for (Index j = 0; j < 4; ++j) {
    std::vector<double> v(S.rows());
    for (Index i = 0; i < S.rows(); ++i) v[i] = S(i, j);
    const double D = ks_statistic(v, [&](double t) { return std::clamp((t - a[j]) / (b[j] - a[j]), 0.0, 1.0); });
    // Bonferroni: 4 tests at 0.25% each; asymptotic critical value sqrt(−ln(0.0025/2)/2)/√n = 1.825/√n.
    const double crit = 1.825 / std::sqrt(800.0);
    MESSAGE("sub-box coordinate " << j << ": KS D = " << D << " (critical " << crit << ")");
    CHECK(D < crit);
  }
}

TEST_CASE("hit_and_run: uniform in a box region without a constraint (its own chord; KS per coordinate)") {
  // A region without a constraint (trust_region, box) takes the box's chord directly: drawing on [0, hi] instead of
  // [lo, hi] put 35 % of the points in the outer fifths and survived every test, which used constrained regions
  // only (mutation testing, session 31).
  const Vec a = (Vec(3) << 0.1, 0.3, 0.0).finished();
  const Vec b = (Vec(3) << 0.5, 0.6, 1.0).finished();
  BoxRegion box(Box{a, b});
  HitAndRunOptions o = iid_options(800);
  o.burn_in = 200;
  HitAndRunSampler sampler(o);
  Rng rng(17);
  const Mat S = sampler.sample(box, 800, rng);
  for (Index j = 0; j < 3; ++j) {
    std::vector<double> v(S.rows());
    for (Index i = 0; i < S.rows(); ++i) v[i] = S(i, j);
    const double D = ks_statistic(v, [&](double t) { return std::clamp((t - a[j]) / (b[j] - a[j]), 0.0, 1.0); });
    const double crit = 1.77 / std::sqrt(800.0);  // Bonferroni over 3 at 1 %: sqrt(−ln(0.01/6)/2) = 1.77
    MESSAGE("box coordinate " << j << ": KS D = " << D << " (critical " << crit << ")");
    CHECK(D < crit);
  }
}

TEST_CASE("hit_and_run: many samples per chain stay inside a non-convex region and reach both parts") {
  TwoBallsRegion two;
  HitAndRunOptions o;
  o.chains = 8;
  HitAndRunSampler sampler(o);
  Rng rng(11);
  HitAndRunStats stats;
  const Mat S = sampler.sample(two, 2000, rng, &stats);
  Index in_second = 0;
  for (Index i = 0; i < S.rows(); ++i) {
    CHECK(two.contains(S.row(i).transpose()));
    if ((S.row(i).transpose() - Vec::Constant(2, 0.65)).norm() < 0.2) ++in_second;
  }
  MESSAGE("two balls: " << in_second << " of 2000 in the second ball; stuck steps " << stats.stuck << " of "
                        << stats.steps);
  CHECK(in_second > 200);  // started only in the first ball
  CHECK(stats.stuck < stats.steps / 100);
}

TEST_CASE("hit_and_run: deterministic per seed whatever the thread count; repeated calls differ") {
  // The chains carry over from call to call: the same sequence of calls with the same seed gives the same samples.
  BallRegion ball(Vec::Constant(5, 0.4), 0.25, Vec::Constant(5, 0.4).transpose());
  auto run = [&](int threads) {
    ThreadLimit limit(threads);
    HitAndRunSampler sampler(HitAndRunOptions{});
    Rng rng(99);
    std::vector<Mat> calls;
    for (int k = 0; k < 3; ++k) calls.push_back(sampler.sample(ball, 600, rng));
    return calls;
  };
  const std::vector<Mat> one = run(1), two = run(2);
  for (std::size_t k = 0; k < one.size(); ++k) CHECK((one[k] - two[k]).cwiseAbs().maxCoeff() == 0.0);
  CHECK((one[0] - one[1]).norm() > 0);
}

TEST_CASE("hit_and_run: chains kept across calls approach the uniform law; restarted every call they do not") {
  // Issue 12, item 10: CRBO calls the sampler once per iteration. Restarted from the data with 10 burn-in steps
  // at every call, the samples stayed near the seeds (the review measured KS D = 0.17 at d = 10); kept chains add
  // their steps up across calls. Known-uniform test region: an elongated box, [0.1, 0.9] × [0.4, 0.6]^9 (an ARD
  // confidence region is elongated like this along its long lengthscales), seeds at its centre; KS of the long
  // coordinate against U(0.1, 0.9).
  const Index d = 10;
  Vec a = Vec::Constant(d, 0.4), b = Vec::Constant(d, 0.6);
  a(0) = 0.1;
  b(0) = 0.9;
  SubBoxRegion slab(a, b);
  auto ks_after = [&](bool keep, int calls) {
    HitAndRunOptions o;
    o.keep_chains = keep;
    HitAndRunSampler sampler(o);
    Rng rng(5);
    Mat S;
    for (int k = 0; k < calls; ++k) S = sampler.sample(slab, 1000, rng);
    std::vector<double> v(static_cast<std::size_t>(S.rows()));
    for (Index i = 0; i < S.rows(); ++i) v[static_cast<std::size_t>(i)] = S(i, 0);
    return ks_statistic(v, [&](double t) { return std::clamp((t - 0.1) / 0.8, 0.0, 1.0); });
  };
  const double restarted = ks_after(false, 10), first = ks_after(true, 1), kept10 = ks_after(true, 10),
               kept30 = ks_after(true, 30);
  MESSAGE("d = 10 slab, KS D: first call " << first << "; 10th call restarted " << restarted << ", kept " << kept10
                                           << "; 30th call kept " << kept30);
  CHECK(restarted > 0.1);
  // The samples of one call are correlated (256 chains, half carried over), so not the i.i.d. critical value
  // 0.052 but ratios to the restarted chains' D.
  CHECK(kept10 < restarted / 1.5);
  CHECK(kept30 < restarted / 3);
}

TEST_CASE("hit_and_run: every seed may start a chain, not only the first `chains` of them") {
  // Two far-apart balls; the first 256 seeds lie in the first, the last 44 in the second. Chains started only
  // from the first 256 seeds (the old round-robin) would hardly ever reach the second ball.
  class TwoFarBalls final : public RegionConstraint {
   public:
    explicit TwoFarBalls(Mat seeds) : seeds_(std::move(seeds)) {}
    const Box& bounds() const override { return box_; }
    bool has_constraint() const override { return true; }
    double constraint(const Vec& x, Vec* g) const override {
      if (g) *g = Vec::Zero(2);
      return std::max(0.01 - (x - Vec::Constant(2, 0.2)).squaredNorm(), 0.01 - (x - Vec::Constant(2, 0.8)).squaredNorm());
    }
    Mat seeds() const override { return seeds_; }

   private:
    Box box_ = Box::unit(2);
    Mat seeds_;
  };
  Mat seeds(300, 2);
  Rng sr(1);
  for (Index i = 0; i < 300; ++i) {
    const Vec centre = Vec::Constant(2, i < 256 ? 0.2 : 0.8);
    seeds.row(i) = (centre + 0.05 * sr.uniform_vec(2) - Vec::Constant(2, 0.025)).transpose();
  }
  TwoFarBalls two(seeds);
  HitAndRunSampler sampler(HitAndRunOptions{});
  Rng rng(8);
  const Mat S = sampler.sample(two, 1000, rng);
  Index in_second = 0;
  for (Index i = 0; i < S.rows(); ++i) in_second += (S.row(i).transpose() - Vec::Constant(2, 0.8)).norm() < 0.1;
  MESSAGE(in_second << " of 1000 samples in the second ball (44 of 300 seeds)");
  CHECK(in_second > 50);
}

TEST_CASE("hit_and_run: an unconstrained region is sampled inside its box; no feasible start throws") {
  BoxRegion box(Box{Vec::Constant(2, 0.2), Vec::Constant(2, 0.3)});
  HitAndRunSampler sampler(HitAndRunOptions{});
  Rng rng(1);
  const Mat S = sampler.sample(box, 50, rng);
  for (Index i = 0; i < S.rows(); ++i) CHECK(box.contains(S.row(i).transpose()));
  // An empty sub-box (lower > upper) has no feasible point at all.
  SubBoxRegion none(Vec::Constant(2, 0.6), Vec::Constant(2, 0.4));
  CHECK_THROWS_AS(sampler.sample(none, 5, rng), NumericalError);
}

TEST_CASE("hit_and_run: registered as a plugin with its options") {
  auto s = test::registry().create<Sampler>("{type: hit_and_run, chains: 4, width: 0.05}", BuildContext{});
  BallRegion ball(Vec::Constant(2, 0.5), 0.1, Vec::Constant(2, 0.5).transpose());
  Rng rng(3);
  const Mat S = s->sample(ball, 20, rng);
  CHECK(S.rows() == 20);
  for (Index i = 0; i < S.rows(); ++i) CHECK(ball.contains(S.row(i).transpose()));
  CHECK_THROWS_AS(test::registry().create<Sampler>("{type: hit_and_run, chains: 0}", BuildContext{}), ConfigError);
}
