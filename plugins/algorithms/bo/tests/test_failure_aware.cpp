// Failure-aware BO (failure_aware.hpp): the weighted acquisition's gradient, the failure utility, and whole
// runs — the repeated-failure regression of issue 11 (a task failing when x1 < 0.25, in-process and through the
// study API as the CLI's suggest → fail cycle uses it), no change without failures, 1 vs 2 threads.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "bo_on_bowl.hpp"
#include "failure_aware.hpp"
#include "study_helpers.hpp"
#include "varbo/errors.hpp"
#include "varbo/function.hpp"
#include "varbo/log.hpp"
#include "varbo/math.hpp"
#include "varbo/study_api.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {

/// The scenarios of sessions fail12–fail14 (Hartmann-3 runs creeping along the failure ball) were found with the
/// Matérn-5/2 kernel, the gp's default until session 16; `kernel: auto` fits some of those runs with SE-ARD and
/// changes their paths, so the tests of those options pin the kernel they were built on.
std::string matern_bo(const std::string& options = "") {
  return "{type: bo, surrogate: {type: gp, kernel: matern52_ard}" + (options.empty() ? "" : ", " + options) + "}";
}

// Styblinski–Tang on [−5, 5]² failing where x1 is in the lowest quarter of its range (x1 < −2.5): the global
// minimizer (−2.90, −2.90) lies inside, so a model that ignores failures keeps being drawn there.
const char* kFailingTask = "{type: styblinski_tang, failure_region: {shape: box, lower: [0, 0], upper: [0.25, 1]}}";
const Box kFailingBox{Vec{{-5.0, -5.0}}, Vec{{5.0, 5.0}}};
const Box kBraninBox{Vec{{-5.0, 0.0}}, Vec{{10.0, 15.0}}};

struct Trial {
  Vec u;  ///< unit cube
  bool ok;
  std::string phase;
};

std::vector<Trial> read_trials(const std::string& folder, const Box& box) {
  const auto rows = test::read_rows(folder + "/trials.csv");
  const int x1 = test::column_of(rows[0], "x1"), x2 = test::column_of(rows[0], "x2");
  const int ok = test::column_of(rows[0], "ok"), phase = test::column_of(rows[0], "phase");
  REQUIRE(x1 >= 0);
  REQUIRE(ok >= 0);
  std::vector<Trial> out;
  for (std::size_t r = 1; r < rows.size(); ++r) {
    Vec theta{{std::stod(rows[r][static_cast<std::size_t>(x1)]), std::stod(rows[r][static_cast<std::size_t>(x2)])}};
    out.push_back({to_unit(theta, box), rows[r][static_cast<std::size_t>(ok)] == "1",
                   rows[r][static_cast<std::size_t>(phase)]});
  }
  return out;
}

std::vector<Trial> run(const std::string& name, const std::string& task, const Box& box, const std::string& algorithm,
                       int budget, int threads, int seed = 3, const std::string& extra = "") {
  RunOverrides ov;
  ov.output = test::temp_folder("failure_aware_" + name);
  ov.threads = threads;
  test::run_yaml("task: " + task + "\nbudget: " + std::to_string(budget) + "\nseed: " + std::to_string(seed) +
                     "\nalgorithm: " + algorithm + "\n" + extra,
                 test::registry(), ov);
  return read_trials(*ov.output, box);
}

/// Smallest distance from a failed trial to any earlier trial (unit cube): 0 for an exact repeat.
double closest_repeat_of_failure(const std::vector<Trial>& t) {
  double d = INFINITY;
  for (std::size_t i = 0; i < t.size(); ++i)
    if (!t[i].ok)
      for (std::size_t j = 0; j < i; ++j) d = std::min(d, (t[i].u - t[j].u).norm());
  return d;
}

Dataset branin_data(const std::vector<Vec>& points) {
  Dataset d = Dataset::empty(2);
  for (const Vec& u : points) {
    const Vec x = from_unit(u, kBraninBox);
    const double a = x(1) - 5.1 / (4 * M_PI * M_PI) * x(0) * x(0) + 5 / M_PI * x(0) - 6;
    d.add(u, a * a + 10 * (1 - 1 / (8 * M_PI)) * std::cos(x(0)) + 10);
  }
  return d;
}

}  // namespace

namespace {

/// A 50-trial run (seed 1, one thread) on a Hartmann-3 task with the given algorithm; every trial in the unit cube
/// (Hartmann-3's box).
std::vector<Trial> hartmann3_trials(const std::string& name, const std::string& algorithm, const std::string& task) {
  RunOverrides ov;
  ov.output = test::temp_folder("failure_aware_" + name);
  ov.threads = 1;
  test::run_yaml("task: " + task + "\nbudget: 50\nseed: 1\nalgorithm: " + algorithm + "\n", test::registry(), ov);
  const auto rows = test::read_rows(*ov.output + "/trials.csv");
  const int x1 = test::column_of(rows[0], "x1"), ok = test::column_of(rows[0], "ok"),
            phase = test::column_of(rows[0], "phase");
  REQUIRE(x1 >= 0);
  std::vector<Trial> out;
  for (std::size_t r = 1; r < rows.size(); ++r) {
    Vec u(3);
    for (int d = 0; d < 3; ++d) u(d) = std::stod(rows[r][static_cast<std::size_t>(x1 + d)]);
    out.push_back({u, rows[r][static_cast<std::size_t>(ok)] == "1", rows[r][static_cast<std::size_t>(phase)]});
  }
  return out;
}

}  // namespace

TEST_CASE("the feasibility-weighted acquisition's gradient matches central differences (ei and cb)") {
  Registry& reg = test::registry();
  BuildContext ctx;
  ctx.registry = &reg;
  ctx.dim = 2;
  Rng rng(5);
  std::vector<Vec> pts;
  for (int i = 0; i < 10; ++i) pts.push_back(rng.uniform_vec(2));
  const Dataset data = branin_data(pts);
  auto gp = reg.create<Surrogate>("{type: gp}", ctx);
  Rng frng(1);
  REQUIRE(gp->fit(data, frng).ok);
  // Successes at the data, failures on a 3 × 3 grid in the corner [0.05, 0.25]², so both the allowed and the
  // excluded (P < 0.2) sides are sampled below.
  Mat X(19, 2);
  X.topRows(10) = data.X;
  std::vector<bool> ok(19, true);
  for (int i = 0; i < 9; ++i) {
    X.row(10 + i) << 0.05 + 0.1 * (i % 3), 0.05 + 0.1 * (i / 3);
    ok[static_cast<std::size_t>(10 + i)] = false;
  }
  bo::FeasibilityModel model(2);
  REQUIRE(model.fit(X, ok, bo::cost_lengthscales(gp->hyperparameters(), 2)));
  for (const char* yaml : {"{type: ei}", "{type: cb, kappa: 1}", "{type: cb, kappa: -2}"}) {
    auto acq = reg.create<Acquisition>(yaml, ctx);
    Rng arng(2);
    acq->prepare({gp.get(), &data, 10, &arng});
    const double u_fail = bo::failure_utility(*acq, data.X);
    if (std::string(yaml) == "{type: ei}") CHECK(u_fail == 0.0);  // EI ≥ 0: a failure improves nothing
    else CHECK(u_fail < 0.0);                                      // cb = −(μ + κσ) is negative on Branin's data
    // weighted: P·(u − u_fail); exclusion only (bo's final refinement): u − u_fail where P ≥ min_probability.
    std::vector<Vec> xs;  // the same points for both modes
    for (int t = 0; t < 40; ++t) xs.push_back(rng.uniform_vec(2));
    for (const bool weighted : {true, false}) {
      bo::FeasibilityWeightedAcquisition w(*acq, model, u_fail, 0.2, weighted);
      FunctionRef f(2, [&](const Vec& x, Vec* g) { return w.evaluate(x, g); });
      int allowed = 0, excluded = 0;
      for (const Vec& x : xs) {
        const double p = model.probability(x);
        if (std::abs(p - 0.2) < 1e-3) continue;  // the kink at min_probability
        const GradientCheck c = check_gradient(f, x, 1e-6, 1e-8);
        CAPTURE(yaml);
        CAPTURE(weighted);
        CAPTURE(p);
        CHECK(c.max_rel_error < 1e-5);
        (p >= 0.2 ? allowed : excluded)++;
        if (p >= 0.2) {
          CHECK(w.evaluate(x, nullptr) >= -1e-12);  // allowed points never score below excluded ones
          // The two modes differ by the factor P, computed independently here.
          const double u = acq->evaluate(x, nullptr) - u_fail;
          CHECK(w.evaluate(x, nullptr) == doctest::Approx(weighted ? p * u : u).epsilon(1e-12));
        } else {
          CHECK(w.evaluate(x, nullptr) < 0.0);
        }
      }
      CHECK(allowed > 0);
      CHECK(excluded > 0);
    }
  }
}

TEST_CASE("issue 11 regression: BO leaves a failure region instead of repeating the failing θ") {
  // 6 initial points + 18 BO trials, as in the audit (there all 18 failed at one θ).
  const std::vector<Trial> t = run("x1_quarter", kFailingTask, kFailingBox, "{type: bo}", 24, 2);
  REQUIRE(t.size() == 24);
  int failed_after_design = 0, failed_last_half = 0;
  for (std::size_t i = 6; i < t.size(); ++i) {
    failed_after_design += !t[i].ok;
    failed_last_half += i >= 15 && !t[i].ok;
  }
  const double repeat = closest_repeat_of_failure(t);
  std::printf("x1 < 0.25 task: %d of 18 BO trials failed (%d of the last 9); closest repeat of a failure %.3g\n",
              failed_after_design, failed_last_half, repeat);
  CHECK(repeat > 0.02);             // no failed θ is a repeat (the audit: 18 at one θ)
  CHECK(failed_after_design <= 4);  // it leaves the failure region
  CHECK(failed_last_half == 0);

  // The same run ignoring failures (the behaviour before) does repeat: the test can tell the difference.
  const std::vector<Trial> off = run("x1_quarter_off", kFailingTask, kFailingBox, "{type: bo, failure_model: {enabled: off}}", 24, 2,
                                       3, "stop_after_failures: 0\n");  // it fails on and on: that is the point
  int off_failed = 0;
  for (std::size_t i = 6; i < off.size(); ++i) off_failed += !off[i].ok;
  std::printf("  with failure_model off: %d of 18 BO trials failed; closest repeat %.3g\n", off_failed,
              closest_repeat_of_failure(off));
  CHECK(off_failed > failed_after_design);
}

TEST_CASE("issue 11 regression: suggest → fail cycles through the study API give distinct points") {
  // What `varbo suggest` / `varbo fail` do: each cycle opens the study afresh (replaying it) and fails the
  // suggested trial. The design's 6 points are observed; then every suggestion fails.
  const std::string folder = test::temp_folder("failure_aware_study");
  const std::string store = folder + "/s.db";
  const StudyConfig cfg = parse_study(
      ConfigNode::parse("task: {type: branin}\nbudget: 30\nseed: 3\nalgorithm: {type: bo}\n", "<test>"),
      test::registry());
  {
    Study s = Study::attach(store, cfg, test::registry());
    for (int i = 0; i < 6; ++i) {
      const TrialRecord r = s.ask().at(0);
      Rng rng(static_cast<std::uint64_t>(i));
      s.tell(r.id, s.task().evaluate(r.theta, rng).cost);
    }
  }
  std::vector<Vec> failed;
  for (int cycle = 0; cycle < 6; ++cycle) {
    Study s = Study::attach(store, cfg, test::registry());
    const TrialRecord r = s.ask().at(0);
    failed.push_back(r.x);
    s.fail(r.id, "the robot fell");
  }
  double closest = INFINITY;
  for (std::size_t i = 0; i < failed.size(); ++i)
    for (std::size_t j = 0; j < i; ++j) closest = std::min(closest, (failed[i] - failed[j]).norm());
  std::printf("study API: 6 failed suggestions, closest pair %.3g apart (unit cube)\n", closest);
  CHECK(closest > 0.02);  // the audit: 5 points within 2e-5
}

TEST_CASE("without failures the failure model changes nothing; with failures, 1 and 2 threads agree") {
  const std::vector<Trial> plain = run("plain", "{type: branin}", kBraninBox, "{type: bo}", 14, 2);
  const std::vector<Trial> off = run("plain_off", "{type: branin}", kBraninBox, "{type: bo, failure_model: {enabled: off}}", 14, 2);
  REQUIRE(plain.size() == off.size());
  for (std::size_t i = 0; i < plain.size(); ++i) CHECK((plain[i].u - off[i].u).norm() == 0.0);

  const std::vector<Trial> one = run("threads1", kFailingTask, kFailingBox, "{type: bo}", 16, 1);
  const std::vector<Trial> two = run("threads2", kFailingTask, kFailingBox, "{type: bo}", 16, 2);
  REQUIRE(one.size() == two.size());
  int failures = 0;
  for (std::size_t i = 0; i < one.size(); ++i) {
    CHECK((one[i].u - two[i].u).norm() == 0.0);
    CHECK(one[i].ok == two[i].ok);
    failures += !one[i].ok;
  }
  CHECK(failures > 0);  // the failure model was in use
}

TEST_CASE("each failed design point is replaced once, right after the design, where the task succeeds") {
  // The x1 < 0.25 task: a 6-point design on [0, 1]² puts 1 or 2 points in the failed quarter.
  const std::vector<Trial> t = run("replace", kFailingTask, kFailingBox,
                                   "{type: bo, failure_model: {replace_design: true}}", 16, 2);
  const std::vector<Trial> kept = run("replace_off", kFailingTask, kFailingBox, "{type: bo}", 16, 2);
  REQUIRE(t.size() == 16);
  int design_failed = 0;
  for (std::size_t i = 0; i < 6; ++i) {
    CHECK((t[i].u - kept[i].u).norm() == 0.0);  // the design itself is unchanged
    design_failed += !t[i].ok;
  }
  REQUIRE(design_failed > 0);
  for (std::size_t i = 6; i < t.size(); ++i) {
    CAPTURE(i);
    const bool replacement = i < 6 + static_cast<std::size_t>(design_failed);
    CHECK((t[i].phase == "replace") == replacement);
    if (replacement) {
      CHECK(t[i].ok);
      CHECK(t[i].u(0) >= 0.25);
    }
  }
  CHECK(kept[6].phase != "replace");
}

TEST_CASE("failure_model options are validated") {
  const char* bad[] = {"{type: bo, failure_model: {enabled: maybe}}", "{type: bo, failure_model: {min_probability: 1}}",
                       "{type: bo, failure_model: {min_prob: 0.1}}", "{type: bo, failure_model: 3}",
                       "{type: bo, failure_model: {lengthscales: diagonal}}",
                       "{type: bo, failure_model: {refine_min_probability: 1}}",
                       "{type: bo, failure_model: {replace_design: 3}}",
                       "{type: bo, failure_model: {stall_value: 1}}", "{type: bo, failure_model: {stall_value: -0.1}}",
                       "{type: bo, failure_model: {stall_scale: max}}", "{type: bo, failure_model: {stall_strict: 2}}",
                       "{type: bo, failure_model: {stall_incumbent: -2}}",
                       "{type: bo, failure_model: {stall_remaining: -1}}",
                       "{type: bo, failure_model: {stall_attempt: 2}}",
                       "{type: bo, failure_model: {repeat_distance: 1}}",
                       "{type: bo, failure_model: {repeat_distance: -1e-9}}",
                       "{type: bo, failure_model: {boundary_restart: 3}}",
                       "{type: bo, failure_model: {boundary_reach: 0}}",
                       "{type: bo, failure_model: {boundary_reach: 1.5}}",
                       "{type: bo, failure_model: {boundary_tabu: -0.1}}",
                       "{type: bo, failure_model: {incumbent_level: attempt}}",
                       "{type: bo, failure_model: {feasible_region: on}}",
                       "{type: bo, failure_model: {feasible_shrink: third}}",
                       "{type: bo, failure_model: {feasible_margin: -0.1}}",
                       "{type: bo, failure_model: {feasible_after: 0}}",
                       "{type: bo, failure_model: {attempt_memory: 1.5}}",
                       "{type: bo, failure_model: {boundary_jump: true}}",
                       "{type: bo, failure_model: {follow_probe: -0.1}}",
                       "{type: bo, failure_model: {follow_distance: 0}}",
                       "{type: bo, failure_model: {follow_memory: 1.5}}",
                       "{type: bo, failure_model: {follow_block: -0.1}}"};
  BuildContext ctx;
  ctx.registry = &test::registry();
  ctx.dim = 2;
  ctx.budget = 10;
  for (const char* a : bad) {
    CAPTURE(a);
    CHECK_THROWS_AS(test::registry().create<Algorithm>(a, ctx), ConfigError);
  }
  CHECK_NOTHROW(test::registry().create<Algorithm>("{type: bo, failure_model: {enabled: on, min_probability: 0.05}}", ctx));
}

TEST_CASE("the resolved configuration names every failure_model setting, given ones as given") {
  // So a study resumed by a later version keeps the failure model it was created with, even if a default changes
  // (before, failure_model was resolved only as far as the user wrote it, and left out entirely by default).
  std::vector<std::string> names;
  for (const auto& spec : bo::failure_model_options()) names.push_back(spec.name);
  for (const char* algorithm : {"{type: bo}", "{type: bo, failure_model: {min_probability: 0.3, replace_design: true}}"}) {
    CAPTURE(algorithm);
    const StudyConfig cfg = parse_study(
        ConfigNode::parse(std::string("task: {type: branin}\nbudget: 10\nalgorithm: ") + algorithm + "\n", "<test>"),
        test::registry());
    const YAML::Node fm = cfg.resolved()["algorithm"]["failure_model"];
    REQUIRE(fm.IsMap());
    std::vector<std::string> keys;
    for (const auto& kv : fm) keys.push_back(kv.first.as<std::string>());
    CHECK(keys == names);
    const bool given = std::string(algorithm).find("0.3") != std::string::npos;
    CHECK(fm["min_probability"].as<double>() == (given ? 0.3 : 0.5));
    CHECK(fm["replace_design"].as<bool>() == given);
    CHECK(fm["enabled"].as<std::string>() == "auto");
    // The resolved text parses back to itself (the stored identity of a study is compared this way).
    const std::string text = YAML::Dump(cfg.resolved());
    const StudyConfig again = parse_study(ConfigNode::parse(text, "<resolved>"), test::registry());
    CHECK(YAML::Dump(again.resolved()) == text);
  }
}

TEST_CASE("cost_lengthscales reads ARD and composite kernels of gp and vhgp, never g's") {
  const Hyperparameters gp = {{"lengthscale[0]", 0.3}, {"lengthscale[1]", 0.4}, {"signal_std", 1.0}};
  const Hyperparameters composite = {{"terms[0].lengthscale[0]", 0.3}, {"terms[1].lengthscale[0]", 0.7},
                                     {"terms[0].lengthscale_g[1]", 5.0}, {"terms[0].lengthscale_f[1]", 0.4},
                                     {"xlengthscale_f[1]", 9.0}};
  const Vec a = bo::cost_lengthscales(gp, 2), b = bo::cost_lengthscales(composite, 2);
  CHECK(a(0) == 0.3);
  CHECK(a(1) == 0.4);
  CHECK(b(0) == 0.3);  // the first term that names dimension 0
  CHECK(b(1) == 0.4);  // f's, not g's, and not a name that merely ends like it
  CHECK(bo::cost_lengthscales({}, 2)(1) == 0.2);
  // An isotropic kernel's one length scale holds for every coordinate (it was ignored: 0.2; session 30).
  const Vec iso = bo::cost_lengthscales({{"lengthscale", 0.35}, {"signal_std", 1.0}}, 2);
  CHECK(iso(0) == 0.35);
  CHECK(iso(1) == 0.35);
  CHECK(bo::cost_lengthscales({{"lengthscale[0]", 0.3}, {"lengthscale", 0.9}}, 2)(0) == 0.3);  // ARD first
}

TEST_CASE("stall_value and its variants: no change without failures; they reach the trust region once trials fail") {
  // failh6d. Without failures the rule is never set (identical trials); test_trust_region.cpp tests the rule itself.
  // Off (stall_value: 0) is the reference; the default since session 19 is the recent form, among the variants.
  const std::string off = "{type: bo, failure_model: {stall_value: 0}}";
  const std::vector<std::string> variants = {
      off, "{type: bo, failure_model: {stall_value: 0.001}}",
      "{type: bo, failure_model: {stall_value: 0.001, stall_scale: range, stall_strict: true}}",
      "{type: bo, failure_model: {stall_value: 0.001, stall_scale: std, stall_incumbent: 0.01}}",
      "{type: bo, failure_model: {stall_value: 0.001, stall_scale: range, stall_strict: true, stall_attempt: true}}",
      "{type: bo, failure_model: {stall_value: 0.001, stall_scale: recent, stall_strict: true, stall_attempt: true}}",
      "{type: bo, failure_model: {repeat_distance: 0.001}}", "{type: bo, failure_model: {repeat_distance: 1e-9}}",
      "{type: bo, failure_model: {boundary_restart: true, boundary_reach: 0.2, boundary_tabu: 0.2}}",
      "{type: bo, failure_model: {incumbent_level: fixed}}",
      "{type: bo, failure_model: {feasible_region: both}}",
      "{type: bo, failure_model: {feasible_region: both, feasible_shrink: halve, feasible_margin: 1}}",
      "{type: bo, failure_model: {attempt_memory: 0.1}}", "{type: bo, failure_model: {boundary_jump: edge}}",
      "{type: bo, failure_model: {follow_probe: 1, follow_distance: 0.01, follow_block: 0}}"};
  const std::vector<Trial> plain = run("sv_plain", "{type: branin}", kBraninBox, "{type: bo}", 16, 1);
  for (const std::string& v : variants) {
    CAPTURE(v);
    const std::vector<Trial> p = run("sv_plain_v", "{type: branin}", kBraninBox, v, 16, 1);
    REQUIRE(p.size() == plain.size());
    for (std::size_t i = 0; i < p.size(); ++i) CHECK((p[i].u - plain[i].u).norm() == 0.0);
  }
  // Hartmann-6 with the benchmark's failure slab (docs/failures.md): the first attempt converges within 70 trials,
  // and a value stall (range scale) ends it sooner, so the trials differ from some point after the design on.
  const std::string task =
      "{type: hartmann6, failure_region: {shape: box, lower: [0, 0, 0, 0, 0, 0.7], upper: [1, 1, 1, 1, 1, 1]}}";
  const Box unit{Vec::Zero(2), Vec::Ones(2)};
  const std::vector<Trial> h = run("sv_h6", task, unit, off, 70, 1);
  const std::vector<Trial> sv = run(
      "sv_h6_on", task, unit,
      "{type: bo, failure_model: {stall_value: 0.001, stall_scale: range, stall_strict: false, stall_attempt: false}}",
      70, 1);
  REQUIRE(h.size() == sv.size());
  std::size_t first_difference = h.size();
  for (std::size_t i = 0; i < h.size() && first_difference == h.size(); ++i)
    if ((h[i].u - sv[i].u).norm() > 0) first_difference = i;
  CHECK(first_difference > 14);  // the design and the first model-based trials are the same
  CHECK(first_difference < h.size());
  // stall_remaining: value stalls count only while at least that many trials remain; with the whole budget (70)
  // they never do, so the run is the plain one.
  const std::vector<Trial> never = run(
      "sv_h6_never", task, unit,
      "{type: bo, failure_model: {stall_value: 0.001, stall_scale: range, stall_strict: false, stall_attempt: false, "
      "stall_remaining: 70}}",
      70, 1);
  REQUIRE(never.size() == h.size());
  for (std::size_t i = 0; i < h.size(); ++i) CHECK((never[i].u - h[i].u).norm() == 0.0);
  // stall_attempt (fail12): value stalls count only while the trials left (70 − k) are at least those the attempt
  // has used (k − its first trial, ≤ k); up to trial 35 that holds for every attempt, so the first 36 trials are
  // the ungated rule's.
  const std::vector<Trial> gated = run(
      "sv_h6_attempt", task, unit,
      "{type: bo, failure_model: {stall_value: 0.001, stall_scale: range, stall_strict: false, stall_attempt: true}}",
      70, 1);
  REQUIRE(gated.size() == h.size());
  for (std::size_t i = 0; i <= 35; ++i) CHECK((gated[i].u - sv[i].u).norm() == 0.0);
  // The default (session 19; not strict since session 40) is the attempt-gated rule on the recent scale, trial for
  // trial; it acts at the
  // benchmark's budget of 100 (bench_failures, seed 1: the first attempt, converged in Hartmann-6's local basin,
  // hands over sooner than with the rule off).
  const std::vector<Trial> off100 = run("sv_h6_off100", task, unit, off, 100, 1, 1);
  const std::vector<Trial> plain_h6 = run("sv_h6_default", task, unit, "{type: bo}", 100, 1, 1);
  const std::vector<Trial> written = run(
      "sv_h6_written", task, unit,
      "{type: bo, failure_model: {stall_value: 0.001, stall_scale: recent, stall_strict: false, stall_attempt: true}}",
      100, 1, 1);
  REQUIRE(plain_h6.size() == off100.size());
  REQUIRE(written.size() == off100.size());
  std::size_t gate_difference = off100.size();
  for (std::size_t i = 0; i < off100.size(); ++i) {
    CHECK((plain_h6[i].u - written[i].u).norm() == 0.0);
    if (gate_difference == off100.size() && (written[i].u - off100[i].u).norm() > 0) gate_difference = i;
  }
  CHECK(gate_difference > 14);
  CHECK(gate_difference < off100.size());
}

TEST_CASE("repeat_distance: an attempt that proposes its own point restarts afresh instead of repeating it") {
  // creep12. Hartmann-3 with bench_failures' ball (seed 1): the plain run's first attempt creeps along the ball's
  // edge and then re-evaluates its incumbent exactly (docs/failures.md, session fail12). With the rule, no attempt
  // repeats one of its own points (the final refinement may: it is not an attempt), and a fresh start comes sooner.
  const std::string ball = "failure_region: {shape: ball, center: [0.45, 0.55, 0.55], radius: 0.415}}";
  const std::string task = "{type: hartmann3, " + ball, noisy = "{type: hartmann3, noise_std: 0.01, " + ball;
  const auto trials = [](const std::string& name, const std::string& algorithm, const std::string& t) {
    return hartmann3_trials(name, algorithm, t);
  };
  // Trials (outside the final refinement) that repeat an earlier successful trial exactly; the first restart.
  const auto repeats = [](const std::vector<Trial>& t) {
    int n = 0;
    for (std::size_t i = 0; i < t.size(); ++i)
      for (std::size_t j = 0; j < i && t[i].phase != "refine"; ++j)
        if (t[j].ok && (t[i].u - t[j].u).lpNorm<Eigen::Infinity>() == 0.0) {
          ++n;
          break;
        }
    return n;
  };
  const auto first_restart = [](const std::vector<Trial>& t) {  // a fresh start's first point may be a global probe
    for (std::size_t i = 0; i < t.size(); ++i)
      if (t[i].phase == "restart" || t[i].phase == "probe") return i;
    return t.size();
  };
  // Without session 41's probes during an attempt (probe_every: 0), which take seed 1 behind the ball before it creeps.
  const std::vector<Trial> plain = trials("rd_plain", matern_bo("failure_model: {probe_every: 0}"), task);
  const std::vector<Trial> rule =
      trials("rd_rule", matern_bo("failure_model: {repeat_distance: 1e-9, probe_every: 0}"), task);
  REQUIRE(plain.size() == 50);
  REQUIRE(rule.size() == 50);
  CHECK(repeats(plain) >= 2);  // the behaviour the rule is for (trials 38, 40, 41 in session fail12)
  CHECK(repeats(rule) == 0);
  CHECK(first_restart(rule) < first_restart(plain));
  // The same trials until the proposal that would have repeated a point.
  for (std::size_t i = 0; i < first_restart(rule); ++i) CHECK((rule[i].u - plain[i].u).norm() == 0.0);
  // Under noise (σ = 0.01 on costs of std ~1: the fitted noise is far above the floor) a repeat is a measurement:
  // the rule stays off and the run is the plain one, although that run repeats points too.
  const std::vector<Trial> noisy_plain = trials("rd_noisy_plain", matern_bo(), noisy);
  const std::vector<Trial> noisy_rule = trials("rd_noisy_rule", matern_bo("failure_model: {repeat_distance: 1e-9}"), noisy);
  REQUIRE(noisy_plain.size() == noisy_rule.size());
  CHECK(repeats(noisy_plain) >= 1);
  for (std::size_t i = 0; i < noisy_plain.size(); ++i) CHECK((noisy_rule[i].u - noisy_plain[i].u).norm() == 0.0);
}

TEST_CASE("boundary_restart: an attempt blocked by the failure boundary restarts afresh; later attempts keep off") {
  // fail13. Hartmann-3 with bench_failures' ball, seed 20 (budget 50): the plain run's first attempt creeps along the
  // ball's edge at x1 ≈ 0.74 (trials 22–37) towards the valley x2 ≈ 0.55, x3 ≈ 0.855 that continues inside the ball
  // (docs/failures.md). With the rule the attempt ends at the first model-based trial whose attempt's best point has
  // a failed trial within boundary_reach ahead along the cost model's descent.
  const std::string task =
      "{type: hartmann3, failure_region: {shape: ball, center: [0.45, 0.55, 0.55], radius: 0.415}}";
  const std::string on = matern_bo("failure_model: {boundary_restart: true}");
  std::vector<double> costs;  // of the latest run (NaN where it failed)
  const auto trials = [&](const std::string& name, const std::string& algorithm, int threads = 1) {
    RunOverrides ov;
    ov.output = test::temp_folder("failure_aware_" + name);
    ov.threads = threads;
    test::run_yaml("task: " + task + "\nbudget: 50\nseed: 20\nalgorithm: " + algorithm + "\n", test::registry(), ov);
    const auto rows = test::read_rows(*ov.output + "/trials.csv");
    const int x1 = test::column_of(rows[0], "x1"), ok = test::column_of(rows[0], "ok"),
              phase = test::column_of(rows[0], "phase"), cost = test::column_of(rows[0], "cost");
    REQUIRE(x1 >= 0);
    REQUIRE(cost >= 0);
    std::vector<Trial> out;
    costs.clear();
    for (std::size_t r = 1; r < rows.size(); ++r) {
      Vec u(3);  // Hartmann-3's box is the unit cube
      for (int d = 0; d < 3; ++d) u(d) = std::stod(rows[r][static_cast<std::size_t>(x1 + d)]);
      const bool success = rows[r][static_cast<std::size_t>(ok)] == "1";
      out.push_back({u, success, rows[r][static_cast<std::size_t>(phase)]});
      costs.push_back(success ? std::stod(rows[r][static_cast<std::size_t>(cost)]) : NAN);
    }
    return out;
  };
  const std::vector<Trial> plain = trials("br_plain", matern_bo());
  const std::vector<Trial> rule = trials("br_rule", on);
  const std::vector<double> rule_costs = costs;
  REQUIRE(plain.size() == 50);
  REQUIRE(rule.size() == 50);
  std::size_t restart = rule.size();
  for (std::size_t i = 0; i < rule.size() && restart == rule.size(); ++i)
    if (rule[i].phase == "restart") restart = i;
  std::size_t plain_restart = plain.size();
  for (std::size_t i = 0; i < plain.size() && plain_restart == plain.size(); ++i)
    if (plain[i].phase == "restart") plain_restart = i;
  REQUIRE(restart < plain_restart);
  // Identical until then; a fresh start needs 2 designs plus the refinement (2·8 + 4) left.
  for (std::size_t i = 0; i < restart; ++i) CHECK((rule[i].u - plain[i].u).norm() == 0.0);
  CHECK(50 - restart >= 20);
  // The blocked point: the attempt's best before the restart, with the ball's edge right beside it (a failed trial
  // within 0.05) — checked on the task's own region, not the model's.
  const Vec centre{{0.45, 0.55, 0.55}};
  std::size_t best = 0;
  double best_cost = 1e300;
  bool failed_beside = false;
  for (std::size_t i = 0; i < restart; ++i)
    if (!rule[i].ok) {
      CHECK((rule[i].u - centre).norm() <= 0.415 + 1e-12);  // failed trials are inside the ball
    }
  // The attempt's best point lies on the ball's edge (within 0.02 outside it).
  for (std::size_t i = 0; i < restart; ++i)
    if (rule[i].ok && rule_costs[i] < best_cost) {
      best_cost = rule_costs[i];
      best = i;
    }
  const double edge = (rule[best].u - centre).norm() - 0.415;
  CHECK(edge > 0);
  CHECK(edge < 0.02);
  for (std::size_t i = 0; i < restart; ++i)
    if (!rule[i].ok && (rule[i].u - rule[best].u).lpNorm<Eigen::Infinity>() <= 0.05) failed_beside = true;
  CHECK(failed_beside);
  // Later attempts' model-based trials (not the design, not the refinement) keep boundary_tabu (0.05) away from it.
  for (std::size_t i = restart; i < rule.size(); ++i)
    if (rule[i].phase != "restart" && rule[i].phase != "refine") {
      CAPTURE(i);
      CHECK((rule[i].u - rule[best].u).lpNorm<Eigen::Infinity>() >= 0.05);
    }
  // A seed fixes the run whatever the thread count.
  const std::vector<Trial> two = trials("br_rule_2", on, 2);
  REQUIRE(two.size() == rule.size());
  for (std::size_t i = 0; i < rule.size(); ++i) CHECK((two[i].u - rule[i].u).norm() == 0.0);
  // With the whole budget too short for a fresh start (2·8 + 4 trials) the rule never acts: the plain run.
  const std::vector<Trial> late = trials("br_late", "{type: bo, initial_points: 24, failure_model: {boundary_restart: true}}");
  const std::vector<Trial> late_plain = trials("br_late_plain", "{type: bo, initial_points: 24}");
  REQUIRE(late.size() == late_plain.size());
  for (std::size_t i = 0; i < late.size(); ++i) CHECK((late[i].u - late_plain[i].u).norm() == 0.0);
}

TEST_CASE("feasible_region: failed model-based trials reach the trust region; the run is the plain one until then") {
  // fail14. Hartmann-3 with bench_failures' ball (seed 1, budget 50): with feasible_region: failed (feasible_shrink:
  // halve) each failed model-based trial halves the trust region at the next update, so the runs are identical up to
  // and including the first failed trial after the design and differ later; test_trust_region.cpp tests the counting.
  const std::string task =
      "{type: hartmann3, failure_region: {shape: ball, center: [0.45, 0.55, 0.55], radius: 0.415}}";
  const Box unit{Vec::Zero(2), Vec::Ones(2)};
  const auto trials = [&](const std::string& name, const std::string& algorithm) {
    RunOverrides ov;
    ov.output = test::temp_folder("failure_aware_" + name);
    ov.threads = 1;
    test::run_yaml("task: " + task + "\nbudget: 50\nseed: 1\nalgorithm: " + algorithm + "\n", test::registry(), ov);
    return read_trials(*ov.output, unit);  // x1, x2 of the unit cube: enough to tell trials apart
  };
  const std::vector<Trial> plain = trials("fr_plain", "{type: bo}");
  for (const char* mode : {"failed", "both"}) {
    CAPTURE(mode);
    const std::vector<Trial> rule =
        trials("fr_rule", std::string("{type: bo, failure_model: {feasible_region: ") + mode + ", feasible_shrink: halve}}");
    REQUIRE(rule.size() == plain.size());
    std::size_t first_failed = plain.size();
    for (std::size_t i = 8; i < plain.size() && first_failed == plain.size(); ++i)
      if (!plain[i].ok) first_failed = i;
    REQUIRE(first_failed < 40);
    std::size_t first_difference = plain.size();
    for (std::size_t i = 0; i < plain.size() && first_difference == plain.size(); ++i)
      if ((plain[i].u - rule[i].u).norm() > 0) first_difference = i;
    CHECK(first_difference > 8);  // the design and the first model-based trial are the plain run's
    CHECK(first_difference < plain.size());
    // "failed" can act only after a failed model-based trial; "both" may act after a limited step before it.
    if (std::string(mode) == "failed") CHECK(first_difference > first_failed);
  }
}

TEST_CASE("boundary_jump: edge probes the box's face past the failure zone once, where the blocked attempt creeps") {
  // fail14. Hartmann-3 with bench_failures' ball, seed 1 (budget 50): the plain run's first attempt is blocked at its
  // best point on the ball's edge (x1 ≈ 0.73, trial 38; docs/failures.md, session fail13); the cost model's descent
  // points along −x1 through the ball, and the ray leaves the box (x1 = 0) before the classifier's P(success) is back
  // above the exclusion threshold, so "far" does not probe and "edge" probes the last point in the box.
  const std::string task =
      "{type: hartmann3, failure_region: {shape: ball, center: [0.45, 0.55, 0.55], radius: 0.415}}";
  const auto trials = [&](const std::string& name, const std::string& algorithm) {
    return hartmann3_trials(name, algorithm, task);
  };
  // Without session 41's probes during an attempt (probe_every: 0), which take seed 1 behind the ball before it creeps,
  // and without session 43's cap on the trust region (test::kNoSideCap).
  const std::vector<Trial> plain = trials("bj_plain", matern_bo("failure_model: {probe_every: 0, " + test::kNoSideCap + "}"));
  const std::vector<Trial> edge =
      trials("bj_edge", matern_bo("failure_model: {boundary_jump: edge, probe_every: 0, " + test::kNoSideCap + "}"));
  const std::vector<Trial> far =
      trials("bj_far", matern_bo("failure_model: {boundary_jump: far, probe_every: 0, " + test::kNoSideCap + "}"));
  REQUIRE(edge.size() == plain.size());
  REQUIRE(far.size() == plain.size());
  std::vector<std::size_t> jumps;
  for (std::size_t i = 0; i < edge.size(); ++i)
    if (edge[i].phase == "jump") jumps.push_back(i);
  REQUIRE(jumps.size() == 1);  // once per blocked point
  const std::size_t j = jumps[0];
  for (std::size_t i = 0; i < j; ++i) CHECK((edge[i].u - plain[i].u).norm() == 0.0);  // the plain run until then
  for (std::size_t i = 0; i < far.size(); ++i) CHECK((far[i].u - plain[i].u).norm() == 0.0);  // far never probes here
  // The probe lies on the box's face x1 = 0 (within one scan step of 0.01), across the ball from the blocked best
  // point (x1 > 0.7), and outside the ball: the task's own region says so.
  CHECK(edge[j].u(0) < 0.01);
  const Vec centre{{0.45, 0.55, 0.55}};
  CHECK((edge[j].u - centre).norm() > 0.415);
  CHECK(edge[j].ok);
  double blocked_x1 = 1;
  for (std::size_t i = 8; i < j; ++i)
    if (plain[i].phase != "restart") blocked_x1 = std::min(blocked_x1, plain[i].ok ? plain[i].u(0) : 1.0);
  CHECK(blocked_x1 > 0.5);  // the attempt never went past the ball on its own
}

TEST_CASE("failure-aware bo: a failed initial policy is not run again by the random fallback") {
  // CRBO's design (around_initial_point) gives θ0 as its first point every time it is asked for one, and the
  // "fewer than 2 successful trials" fallback drew its random points from it: a θ0 that failed (the robot fell)
  // was run on every remaining trial (red team, session 26).
  set_log_level(LogLevel::Error);
  BuildContext ctx;
  ctx.dim = 3;
  ctx.budget = 14;
  ctx.seed = 2;
  ctx.initial_point = Vec::Constant(3, 0.5);
  auto a = test::registry().create<Algorithm>(
      "{type: bo, initial_design: {type: around_initial_point}, initial_points: 3, "
      "region: {type: confidence, gamma: 0.6}, acquisition_optimizer: sample_polish}",
      ctx);
  // Everything within 0.3 of θ0 (∞-norm, unit cube) fails.
  const auto fails = [](const Vec& x) { return (x.array() - 0.5).abs().maxCoeff() < 0.3; };
  std::vector<Vec> failed;
  for (Index k = 0; k < 14; ++k) {
    const Suggestion s = a->ask(1).front();
    CAPTURE(k);
    for (const Vec& f : failed) CHECK((s.x - f).lpNorm<Eigen::Infinity>() > 1e-9);
    const bool ok = !fails(s.x);
    a->tell({Observation{s.x, ok ? (s.x.array() - 0.1).square().sum() : std::nan(""), ok, {}}});
    if (!ok) failed.push_back(s.x);
  }
  CHECK(failed.size() < 10);
}

TEST_CASE("failure-aware bo: in 10 dimensions too, a failed θ0 is not run again by the random fallback") {
  // Audit, session 48: with d = 10 a confidence region is a sliver of its box; the fallback's 256 uniform points of
  // the box found none inside it and returned the design sampler's point, θ0, which had failed: trials 7–15 all at
  // θ0 until stop_after_failures. Only θ0 fails here; far from it (over 0.4, unit cube) everything fails too, so
  // the acquisition's best points are often excluded and the fallback is exercised.
  set_log_level(LogLevel::Error);
  BuildContext ctx;
  ctx.dim = 10;
  ctx.budget = 20;
  ctx.seed = 2;
  ctx.initial_point = Vec::Constant(10, 0.65);
  auto a = test::registry().create<Algorithm>(
      "{type: bo, initial_design: {type: around_initial_point}, initial_points: 4, "
      "surrogate: {type: gp, kernel: matern52_ard, restarts: 2}, acquisition: {type: cb, kappa: -2}, "
      "region: {type: confidence, gamma: 0.6}, acquisition_optimizer: sample_polish}",
      ctx);
  const Vec theta0 = Vec::Constant(10, 0.65);
  const auto fails = [&](const Vec& x) { return (x - theta0).norm() < 1e-9 || (x - theta0).norm() > 0.4; };
  int at_theta0 = 0, random_trials = 0;
  for (Index k = 0; k < 20; ++k) {
    const Suggestion s = a->ask(1).front();
    CAPTURE(k);
    at_theta0 += (s.x - theta0).lpNorm<Eigen::Infinity>() <= 1e-9;
    random_trials += s.phase == "random";
    const bool ok = !fails(s.x);
    a->tell({Observation{s.x, ok ? (s.x.array() - 0.95).square().sum() / 10 : std::nan(""), ok, {}}});
  }
  CHECK(at_theta0 == 1);  // the design's first point only
  CHECK(random_trials > 0);  // the fallback did run
}
