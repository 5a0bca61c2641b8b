// select_policies (varbo/select.hpp): risk-sensitive selection on a fitted model, Kuindersma 2013 eq. (20).
#include <cmath>
#include <filesystem>

#include "fake_two_wells.hpp"
#include "study_helpers.hpp"
#include "varbo/errors.hpp"
#include "varbo/run_folder.hpp"
#include "varbo/select.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {
// The exact argmin of m + κ s over [0, 1] by a 10⁶-point grid (spacing 1e-6).
double grid_argmin(double kappa) {
  double best = 0, best_v = INFINITY;
  for (int i = 0; i <= 1000000; ++i) {
    const double x = i * 1e-6;
    const double v = test::FakeTwoWells::mean(x) + kappa * test::FakeTwoWells::std_dev(x);
    if (v < best_v) {
      best_v = v;
      best = x;
    }
  }
  return best;
}

std::unique_ptr<Optimizer> multistart() {
  BuildContext ctx;
  ctx.dim = 1;
  return test::registry().create<Optimizer>("{type: multistart, candidates: 256, polish: 4}", ctx);
}
}  // namespace

TEST_CASE("the gradient of -(E + kappa s) matches central differences") {
  const test::FakeTwoWells model;
  for (double kappa : {-2.0, -0.5, 0.0, 1.5}) {
    const NegativeConfidenceBound f(model, 1, kappa);
    for (double x : {0.07, 0.31, 0.62, 0.93}) {
      const GradientCheck g = check_gradient(f, Vec::Constant(1, x), 1e-6);
      CHECK(g.max_rel_error < 1e-6);  // central differences, h = 1e-6: truncation error ~1e-10 relative
    }
  }
}

TEST_CASE("select_policies: kappa > 0 picks the low-variance well, kappa < 0 the high-variance one") {
  const test::FakeTwoWells model;
  const Domain domain{Box{Vec::Constant(1, -2.0), Vec::Constant(1, 6.0)}, {"theta"}};  // user units ≠ unit cube
  const auto opt = multistart();
  const std::vector<double> kappas{1.5, -1.5, 0.0, 3.0};
  const std::vector<RiskSelection> sel = select_policies(model, domain, kappas, *opt, Rng(7));
  REQUIRE(sel.size() == 4);
  for (const RiskSelection& s : sel) {
    REQUIRE(s.ok);
    INFO("kappa " << s.kappa << " x " << s.x[0]);
    if (s.kappa != 0.0) CHECK(std::abs(s.x[0] - grid_argmin(s.kappa)) < 1e-5);  // polished optimum vs 1e-6 grid
    CHECK(s.theta[0] == doctest::Approx(-2.0 + 8.0 * s.x[0]).epsilon(1e-12));  // mapped to the domain
    CHECK(s.mean == doctest::Approx(test::FakeTwoWells::mean(s.x[0])).epsilon(1e-12));
    CHECK(s.std == doctest::Approx(test::FakeTwoWells::std_dev(s.x[0])).epsilon(1e-12));
    CHECK(s.criterion == doctest::Approx(s.mean + s.kappa * s.std).epsilon(1e-12));
  }
  // Risk-averse picks the well at 1/4 (s = 0.0325), risk-seeking the one at 3/4 (s = 0.1325) (task README).
  CHECK(std::abs(sel[0].x[0] - 0.25) < 0.05);
  CHECK(std::abs(sel[1].x[0] - 0.75) < 0.05);
  CHECK(std::abs(sel[3].x[0] - 0.25) < 0.05);
  // κ = 0: both wells have mean exactly 0.1; the optimizer may return either, at a true minimum.
  CHECK(sel[2].mean == doctest::Approx(0.1).epsilon(1e-8));
}

TEST_CASE("select_policies: one kappa's answer does not depend on the others, and the seed fixes it") {
  const test::FakeTwoWells model;
  const Domain domain{Box::unit(1), {"theta"}};
  const auto opt = multistart();
  const auto a = select_policies(model, domain, {1.5, -1.5}, *opt, Rng(3));
  const auto b = select_policies(model, domain, {-1.5}, *opt, Rng(3));
  const auto c = select_policies(model, domain, {1.5, -1.5}, *opt, Rng(3));
  CHECK(a[1].x[0] == b[0].x[0]);
  CHECK(a[0].x[0] == c[0].x[0]);
  CHECK(a[1].x[0] == c[1].x[0]);
}

TEST_CASE("select_policies: bad input is an error, a non-finite kappa is reported, not thrown") {
  const test::FakeTwoWells model;
  const auto opt = multistart();
  CHECK_THROWS_AS(select_policies(model, Domain{Box::unit(1), {}}, {1.0}, *opt, Rng(1), Mat::Zero(3, 2)), InputError);
  const auto sel = select_policies(model, Domain{Box::unit(1), {}}, {NAN}, *opt, Rng(1));
  REQUIRE(sel.size() == 1);
  CHECK_FALSE(sel[0].ok);
  CHECK(sel[0].message.find("kappa") != std::string::npos);
}

TEST_CASE("a run folder reads back, refits and selects (two_minima_1d, short VHGP run)") {
  const std::string out = test::temp_folder("vbo_select_run");
  const std::string yaml = "task: {type: two_minima_1d}\nbudget: 12\nseed: 3\noutput: " + out +
                           "\nalgorithm: {type: bo, initial_points: 8, initial_design: uniform, surrogate: {type: vhgp, "
                           "restarts: 4}, acquisition: {type: ei, xi: 1.0}}\n";
  test::run_yaml(yaml, test::registry());
  const RunFolder run = load_run_folder(out, test::registry());
  CHECK(run.trials == 12);
  CHECK(run.data.size() == 12);
  CHECK(run.names == std::vector<std::string>{"theta"});
  CHECK(run.fits.size() == 4);  // one model.yaml entry per fit (trials 9..12)
  const ResolvedComponent* spec = run_surrogate_spec(run);
  REQUIRE(spec != nullptr);
  CHECK(spec->info->name == "vhgp");
  auto model = make_run_surrogate(run, *spec, test::registry(), 1, true);
  const FitReport rep = fit_run_surrogate(*model, run, 1);
  CHECK(rep.ok);
  // Same seed, same answer (the fit and the optimizer are seeded).
  const auto opt = multistart();
  const auto s1 = select_policies(*model, run.domain, {1.5, -1.5}, *opt, Rng(1), run.data.X);
  auto model2 = make_run_surrogate(run, *spec, test::registry(), 1, true);
  fit_run_surrogate(*model2, run, 1);
  const auto s2 = select_policies(*model2, run.domain, {1.5, -1.5}, *opt, Rng(1), run.data.X);
  for (std::size_t k = 0; k < 2; ++k) {
    REQUIRE(s1[k].ok);
    CHECK(s1[k].theta[0] == s2[k].theta[0]);
    CHECK(s1[k].theta[0] >= 0.0);
    CHECK(s1[k].theta[0] <= 1.0);
  }
}

TEST_CASE("load_run_folder: missing files and bad rows name the file") {
  const std::string dir = test::temp_folder("vbo_bad_run");
  CHECK_THROWS_WITH_AS(load_run_folder(dir, test::registry()), doctest::Contains("config.resolved.yaml"), InputError);
  CHECK_THROWS_AS(load_run_folder(dir + "/nope", test::registry()), InputError);
}

TEST_CASE("parameters named like columns of the trials table (index, cost) are refused where they are written") {
  // Session 20 read such columns by position; trials.csv still had two `cost` columns (pandas: cost, cost.1), so
  // a parameter may not take the name of a fixed column: the config names the parameter's line.
  const std::string out = test::temp_folder("vbo_named_columns");
  for (const std::string name : {"index", "cost", "regret_recommended"}) {
    const std::string yaml = "task: {type: external, command: \"cat > /dev/null; echo 1.5\"}\nparameters:\n"
                             "  - {name: a, type: real, low: 10, high: 100}\n"
                             "  - {name: " + name + ", type: real, low: 0, high: 1}\n"
                             "budget: 4\nseed: 1\nalgorithm: {type: random}\noutput: " + out + "/" + name + "\n";
    const std::string expected = "<test study>:4:12: key 'parameters[1].name': '" + name + "' names a column";
    CHECK_THROWS_WITH_AS(test::run_yaml(yaml, test::registry()), doctest::Contains(expected.c_str()), ConfigError);
    CHECK_FALSE(std::filesystem::exists(out + "/" + name));
  }
  // The external task's own `names:` (a box) likewise.
  const std::string box = "task: {type: external, command: \"echo 1\", lower: [0, 0], upper: [1, 1], names: [a, ok]}\n"
                          "budget: 2\nalgorithm: {type: random}\noutput: " + out + "/box\n";
  CHECK_THROWS_WITH_AS(test::run_yaml(box, test::registry()), doctest::Contains("'ok' names a column"), ConfigError);
}

TEST_CASE("select_among: the candidate minimizing E + kappa s, by brute force on the same model") {
  const test::FakeTwoWells model;
  const Domain domain{Box{Vec::Constant(1, 0.0), Vec::Constant(1, 10.0)}, {"theta"}};
  Mat pts(7, 1);
  pts << 0.05, 0.2, 0.26, 0.5, 0.74, 0.8, 0.95;
  for (double kappa : {-1.5, 0.0, 1.5}) {
    const RiskSelection s = select_among(model, domain, {kappa}, pts).front();
    REQUIRE(s.ok);
    Index best = 0;
    for (Index i = 1; i < pts.rows(); ++i) {
      const double xi = pts(i, 0), xb = pts(best, 0);
      if (test::FakeTwoWells::mean(xi) + kappa * test::FakeTwoWells::std_dev(xi) <
          test::FakeTwoWells::mean(xb) + kappa * test::FakeTwoWells::std_dev(xb))
        best = i;
    }
    CHECK(s.x[0] == pts(best, 0));
    CHECK(s.theta[0] == doctest::Approx(10.0 * pts(best, 0)).epsilon(1e-12));
    CHECK(s.criterion == doctest::Approx(s.mean + kappa * s.std).epsilon(1e-12));
  }
  CHECK_THROWS_AS(select_among(model, domain, {0.0}, Mat(0, 1)), InputError);
}

TEST_CASE("the run's model for select/plot: warm-started from its last fit, but with the data mean of all trials, "
          "and a --surrogate with other options is not overridden") {
  // Red team, session 24: the warm start set the gp's `mean` (which fixes the constant mean) to the last fit's
  // value, the mean of the first N - 1 costs; and a --surrogate '{type: gp, prior_mean: max}' got the run's fit.
  const std::string out = test::temp_folder("vbo_select_gp_mean");
  test::run_yaml("task: branin\nbudget: 12\nseed: 1\nthreads: 1\noutput: " + out +
                     "\nalgorithm: {type: bo, initial_points: 8, region: box}\n",
                 test::registry());
  const RunFolder run = load_run_folder(out, test::registry());
  REQUIRE(run.data.size() == 12);
  const ResolvedComponent* own = run_surrogate_spec(run);
  REQUIRE(own != nullptr);
  auto mean_of = [](const Surrogate& m) -> double {
    for (const Hyperparameter& h : m.hyperparameters())
      if (h.name == "mean") return h.value;
    return std::nan("");
  };
  auto warm = make_run_surrogate(run, *own, test::registry(), 1, true);
  fit_run_surrogate(*warm, run, 1);
  auto cold = make_run_surrogate(run, *own, test::registry(), 1, false);
  fit_run_surrogate(*cold, run, 1);
  // The gp's constant mean is the standardized data's (prior_mean: zero): the mean of all 12 costs.
  CHECK(mean_of(*warm) == doctest::Approx(run.data.y.mean()).epsilon(1e-12));
  CHECK(mean_of(*cold) == doctest::Approx(run.data.y.mean()).epsilon(1e-12));
  // Another configuration of the same type keeps its own options: prior_mean: max puts the mean at the top cost.
  const ResolvedComponent max_prior = test::registry().resolve(Kind::Surrogate, ConfigNode::parse("{type: gp, prior_mean: max}", "<test>"));
  auto other = make_run_surrogate(run, max_prior, test::registry(), 1, true);
  fit_run_surrogate(*other, run, 1);
  CHECK(mean_of(*other) == doctest::Approx(run.data.y.maxCoeff()).epsilon(1e-12));
}

namespace {
// A model that only knows "larger x1 is better": mean −x1, no variance. It extrapolates past any failure.
class Slope final : public Surrogate {
 public:
  FitReport fit(const Dataset&, Rng&) override { return {}; }
  FitReport condition(const Dataset&) override { return {}; }
  Prediction predict(const Vec& x, bool with_gradient) const override {
    Prediction p;
    p.mean = -x[0];
    p.log_noise_mean = -30;
    if (with_gradient) {
      p.d_mean = Vec::Zero(x.size());
      p.d_mean[0] = -1;
      p.d_latent_var = p.d_log_noise_mean = p.d_log_noise_var = Vec::Zero(x.size());
    }
    return p;
  }
  double signal_variance() const override { return 1; }
  Hyperparameters hyperparameters() const override { return {}; }
  void set_hyperparameters(const Hyperparameters&) override {}
  bool ready() const override { return true; }
};
}  // namespace

TEST_CASE("select_policies with failed trials: the selection keeps twice as far from every failure as from the "
          "nearest success") {
  // Red team, session 24: trials failed beyond x1 = 0.7 and select chose x1 = 1 (the model extrapolates).
  Domain domain{Box{Vec::Zero(2), Vec::Ones(2)}, {"x1", "x2"}};
  Mat ok(3, 2), failed(2, 2);
  ok << 0.2, 0.5, 0.4, 0.5, 0.6, 0.5;
  failed << 0.75, 0.5, 0.75, 0.9;
  BuildContext ctx;
  ctx.dim = 2;
  const auto opt = test::registry().create<Optimizer>("{type: multistart, candidates: 512, polish: 4}", ctx);
  const Slope model;
  const auto free = select_policies(model, domain, {0.0}, *opt, Rng(1), ok);
  REQUIRE(free[0].ok);
  CHECK(free[0].theta[0] == doctest::Approx(1.0));  // without the failures: the corner
  const auto kept = select_policies(model, domain, {0.0}, *opt, Rng(1), ok, nullptr, failed);
  REQUIRE(kept[0].ok);
  // Along x2 = 0.5 the region around (0.6, 0.5) against (0.75, 0.5) ends a third of the way: x1 = 0.65. Off that
  // line the Apollonius ball of the pair reaches further where the other failure is far enough; the maximum of x1
  // over the region on a grid (spacing 1e-4 in x1, 1e-2 in x2: at most the true maximum) is the reference.
  auto inside = [&](double a, double b) {
    const Vec x = (Vec(2) << a, b).finished();
    const double ds = (ok.rowwise() - x.transpose()).rowwise().squaredNorm().minCoeff();
    const double df = (failed.rowwise() - x.transpose()).rowwise().squaredNorm().minCoeff();
    return df >= 4 * ds;
  };
  double best = 0;
  for (int i = 0; i <= 10000; ++i)
    for (int j = 0; j <= 100; ++j)
      if (inside(i * 1e-4, j * 1e-2)) best = std::max(best, i * 1e-4);
  const double df = (failed.rowwise() - kept[0].x.transpose()).rowwise().squaredNorm().minCoeff();
  const double ds = (ok.rowwise() - kept[0].x.transpose()).rowwise().squaredNorm().minCoeff();
  CHECK(df >= 4 * ds - 1e-9);                  // inside the region (so at most its true maximum)
  CHECK(kept[0].theta[0] >= best - 2e-3);      // and at its maximum, up to the optimizer's tolerance
  CHECK(kept[0].theta[0] < 0.75);
  // Failed points without successful ones are an error, not a silent unconstrained search.
  CHECK_THROWS_AS(select_policies(model, domain, {0.0}, *opt, Rng(1), Mat(), nullptr, failed), InputError);
}
