// gp's kernel_candidates: the kernel chosen by the fit objective, checked against separate single-kernel fits of
// the same data from the same rng; the saved state keeps the choice; bad lists are refused with positions.
#include <cmath>
#include <string>

#include "gp_surrogate.hpp"
#include "kernel_library.hpp"
#include "varbo/config.hpp"
#include "varbo/errors.hpp"
#include "varbo_test.hpp"

using namespace varbo;
using namespace varbo::gp;
using kernels::KernelType;

namespace {

constexpr const char* kCandidates = "{type: gp, kernel_candidates: [matern52_ard, se_ard]}";

std::unique_ptr<Surrogate> make(const std::string& yaml, Index dim) {
  BuildContext ctx;
  ctx.dim = dim;
  return test::registry().create<Surrogate>(yaml, ctx);
}

const GpSurrogate& as_gp(const Surrogate& s) {
  const auto* gp = dynamic_cast<const GpSurrogate*>(&s);
  REQUIRE(gp != nullptr);
  return *gp;
}

Mat random_points(Index n, Index d, Rng& rng) {
  Mat X(n, d);
  for (Index i = 0; i < n; ++i) X.row(i) = rng.uniform_vec(d).transpose();
  return X;
}

/// A noise-free sample of GP(0, SE with ℓ = (0.3, 0.5), σ_f = 1) at 40 uniform points of the unit square: the
/// data the SE prior describes, infinitely smooth.
Dataset smooth_se_sample(std::uint64_t seed) {
  Rng rng(seed);
  const Index n = 40;
  const Mat X = random_points(n, 2, rng);
  kernels::ArdKernel k(KernelType::SquaredExponential, 2);
  k.set_log_params((Vec(3) << std::log(0.3), std::log(0.5), 0.0).finished());
  Mat K = k.matrix(X);
  K.diagonal().array() += 1e-10;  // the sample's own jitter, far below the fit's noise floor relative to std(y)
  return Dataset{X, K.llt().matrixL() * rng.normal_vec(n)};
}

/// |x₀ − 0.37| + 0.5·|x₁ − 0.61| at 40 uniform points: kinked (not differentiable) along two lines, which the
/// SE prior (analytic sample paths) fits worse than Matérn-5/2.
Dataset kinked(std::uint64_t seed) {
  Rng rng(seed);
  const Index n = 40;
  Dataset data{random_points(n, 2, rng), Vec(n)};
  for (Index i = 0; i < n; ++i) data.y(i) = std::abs(data.X(i, 0) - 0.37) + 0.5 * std::abs(data.X(i, 1) - 0.61);
  return data;
}

struct Fits {
  double matern = 0, se = 0, chosen = 0;
  std::size_t choice = 0;
  Hyperparameters chosen_h, matern_h, se_h;
  std::string message;
};

/// The candidate gp and the two single-kernel gps (`kernel:` matern52_ard, se_ard: each with its own noise
/// floor) fitted to the same data from the same rng state.
Fits fit_all(const Dataset& data) {
  Fits f;
  const auto fit = [&](const std::string& yaml, double& objective, Hyperparameters& h) {
    auto gp = make(yaml, 2);
    Rng rng(21);
    const FitReport rep = gp->fit(data, rng);
    REQUIRE(rep.ok);
    objective = rep.objective;
    h = gp->hyperparameters();
    return std::pair<std::unique_ptr<Surrogate>, FitReport>(std::move(gp), rep);
  };
  fit("{type: gp, kernel: matern52_ard}", f.matern, f.matern_h);
  fit("{type: gp, kernel: se_ard}", f.se, f.se_h);
  const auto [gp, rep] = fit(kCandidates, f.chosen, f.chosen_h);
  f.choice = as_gp(*gp).kernel_choice();
  f.message = rep.message;
  MESSAGE("fit objective: matern52_ard " << f.matern << ", se_ard " << f.se << "; " << rep.message);
  return f;
}

void check_same(const Hyperparameters& a, const Hyperparameters& b) {
  REQUIRE(a.size() == b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    CAPTURE(a[i].name);
    CHECK(a[i].name == b[i].name);
    CHECK(a[i].value == doctest::Approx(b[i].value).epsilon(1e-12));
  }
}

}  // namespace

TEST_CASE("kernel_candidates: SE-ARD on a sample of the SE prior, with the objective of the single se_ard fit") {
  const Fits f = fit_all(smooth_se_sample(5));
  CHECK(f.se > f.matern);
  CHECK(f.choice == 1);
  // The candidate's fit is the single-kernel fit (same warm start, same restart streams): equal to 1e-12.
  CHECK(f.chosen == doctest::Approx(f.se).epsilon(1e-12));
  check_same(f.chosen_h, f.se_h);
  CHECK(f.message.find("kernel se_ard") != std::string::npos);
}

TEST_CASE("kernel_candidates: Matérn-5/2 on a kinked function, with the objective of the single matern52_ard fit") {
  const Fits f = fit_all(kinked(6));
  CHECK(f.matern > f.se);
  CHECK(f.choice == 0);
  CHECK(f.chosen == doctest::Approx(f.matern).epsilon(1e-12));
  check_same(f.chosen_h, f.matern_h);
  CHECK(f.message.find("kernel matern52_ard") != std::string::npos);
}

TEST_CASE("kernel_candidates: the chosen kernel's noise floor, and warm-only refits keep the choice") {
  auto gp = make("{type: gp, kernel_candidates: [matern52_ard, se_ard], full_fit_growth: 2}", 2);
  const GpSurrogate& g = as_gp(*gp);
  const auto floor = [&] { return std::exp(g.log_box(2).lower(g.log_box(2).dim() - 1)); };
  CHECK(floor() == doctest::Approx(1e-6).epsilon(1e-12));  // the first candidate's until a fit chooses
  Dataset data = smooth_se_sample(5);
  Rng rng(3);
  REQUIRE(gp->fit(data, rng).ok);
  REQUIRE(g.kernel_choice() == 1);
  CHECK(floor() == doctest::Approx(kSeArdMinNoiseStd).epsilon(1e-12));
  // N 40 → 41 is below full_fit_growth: one warm start of the chosen kernel only, no new choice.
  Rng more(4);
  data.X.conservativeResize(41, 2);
  data.y.conservativeResize(41);
  data.X.row(40) << 0.5, 0.5;
  data.y(40) = 0.0;
  const FitReport rep = gp->fit(data, more);
  CHECK(rep.restarts == 1);
  CHECK(rep.message.find("kernel") == std::string::npos);
  CHECK(g.kernel_choice() == 1);
}

TEST_CASE("kernel_candidates: the saved state restores the choice; the next fits equal the uninterrupted ones") {
  Dataset data = smooth_se_sample(5);
  auto a = make(kCandidates, 2);
  Rng rng(3);
  REQUIRE(a->fit(data, rng).ok);
  REQUIRE(as_gp(*a).kernel_choice() == 1);  // not the first candidate: the restore must set it
  const auto* state = dynamic_cast<const ComponentState*>(a.get());
  REQUIRE(state != nullptr);
  const std::string text = state->save_state();
  auto b = make(kCandidates, 2);
  dynamic_cast<ComponentState&>(*b).restore_state(text);
  CHECK(as_gp(*b).kernel_choice() == 1);
  const Vec x = (Vec(2) << 0.3, 0.7).finished();
  CHECK(a->predict(x, false).mean == b->predict(x, false).mean);
  CHECK(a->predict(x, false).latent_var == b->predict(x, false).latent_var);
  // A warm-only refit and a full refit after the restore, each against the same fits of the original.
  for (const Index n : {41, 60}) {
    CAPTURE(n);
    Rng extra(static_cast<std::uint64_t>(n));
    const Index old = data.size();
    data.X.conservativeResize(n, 2);
    data.y.conservativeResize(n);
    for (Index i = old; i < n; ++i) {
      data.X.row(i) = extra.uniform_vec(2).transpose();
      data.y(i) = std::sin(3 * data.X(i, 0)) * std::cos(2 * data.X(i, 1));
    }
    Rng ra(static_cast<std::uint64_t>(100 + n)), rb(static_cast<std::uint64_t>(100 + n));
    const FitReport fa = a->fit(data, ra), fb = b->fit(data, rb);
    CHECK(fa.objective == fb.objective);
    CHECK(fa.restarts == fb.restarts);
    CHECK(as_gp(*a).kernel_choice() == as_gp(*b).kernel_choice());
    CHECK(a->predict(x, false).mean == b->predict(x, false).mean);
  }
  // Another candidate list, or a single kernel, refuses the state instead of misreading it.
  auto single = make("{type: gp, kernel: se_ard}", 2);
  CHECK_THROWS_AS(dynamic_cast<ComponentState&>(*single).restore_state(text), InputError);
  auto other = make("{type: gp, kernel_candidates: [matern52_ard, matern32_ard]}", 2);
  CHECK_THROWS_WITH_AS(dynamic_cast<ComponentState&>(*other).restore_state(text),
                       doctest::Contains("kernel choice 'se_ard'"), InputError);
}

TEST_CASE("kernel_candidates: bad lists are refused with their position") {
  const auto fails_with = [](const std::string& yaml, const std::string& text) {
    CAPTURE(yaml);
    try {
      make(yaml, 2);
      FAIL("accepted");
    } catch (const ConfigError& e) {
      CAPTURE(e.what());
      CHECK(std::string(e.what()).find(text) != std::string::npos);
      CHECK(std::string(e.what()).find(":1:") != std::string::npos);  // file:line:col
    }
  };
  fails_with("{type: gp, kernel_candidates: [se_ard]}", "at least two kernels");
  fails_with("{type: gp, kernel_candidates: se_ard}", "at least two kernels");
  fails_with("{type: gp, kernel_candidates: [matern52_ard, linear]}", "the same hyperparameters");
  fails_with("{type: gp, kernel_candidates: [matern52_ard, rbf]}", "rbf");
}

TEST_CASE("the resolved configuration gives the same noise floors and tests (min_noise_std, noise_test_level left out unless given)") {
  // A study reopened from its stored configuration builds the gp from the resolved YAML, every default filled in;
  // a declared min_noise_std default would come back as a given 1e-6 and replace se_ard's floor of 1e-7.
  const auto floor_of = [](const Surrogate& s) {
    const Box b = as_gp(s).log_box(2);
    return std::exp(b.lower(b.dim() - 1));
  };
  BuildContext ctx;
  ctx.dim = 2;
  for (const std::string yaml : {"{type: gp, kernel: se_ard}", "{type: gp}", "{type: gp, min_noise_std: 1.0e-5}"}) {
    CAPTURE(yaml);
    const ResolvedComponent c = test::registry().resolve(Kind::Surrogate, ConfigNode::parse(yaml, "<test>"));
    YAML::Emitter em;
    em << c.resolved();
    const std::string resolved = em.c_str();
    CAPTURE(resolved);
    CHECK((resolved.find("min_noise_std") != std::string::npos) == (yaml.find("min_noise_std") != std::string::npos));
    CHECK(floor_of(*make(resolved, 2)) == floor_of(*test::registry().create<Surrogate>(c, ctx)));
    // Likewise the noise test (on by default for se_ard only, session 17): left out, and the same when rebuilt.
    CHECK(resolved.find("noise_test_level") == std::string::npos);
    CHECK(make(resolved, 2)->tests_noise_on_replicates() == (yaml == "{type: gp, kernel: se_ard}"));
  }
  CHECK(floor_of(*make("{type: gp, kernel: se_ard}", 2)) == doctest::Approx(kSeArdMinNoiseStd).epsilon(1e-12));
}

TEST_CASE("kernel_choice_margin: the first candidate within the margin of the best objective") {
  // On the SE sample se_ard wins by ~30 nats (first test case): a margin below that still takes se_ard, one above it
  // keeps the first listed candidate, with exactly the single matern52_ard fit's objective.
  const Dataset data = smooth_se_sample(5);
  Fits f = fit_all(data);
  const double gap = f.se - f.matern;
  REQUIRE(gap > 2.0);
  for (const double margin : {0.5 * gap, 2.0 * gap}) {
    CAPTURE(margin);
    auto gp = make("{type: gp, kernel_candidates: [matern52_ard, se_ard], kernel_choice_margin: " +
                       std::to_string(margin) + "}",
                   2);
    Rng rng(21);
    const FitReport rep = gp->fit(data, rng);
    REQUIRE(rep.ok);
    const bool keeps_first = margin > gap;
    CHECK(as_gp(*gp).kernel_choice() == (keeps_first ? 0u : 1u));
    CHECK(rep.objective == doctest::Approx(keeps_first ? f.matern : f.se).epsilon(1e-12));
  }
  CHECK_THROWS_AS(make("{type: gp, kernel_candidates: [matern52_ard, se_ard], kernel_choice_margin: -1}", 2),
                  ConfigError);
}

TEST_CASE("kernel: auto, the default, is the candidates [matern52_ard, se_ard] with margin 3; a given kernel is one kernel") {
  // Compared fit by fit with the explicit list (same rng): the SE sample, where SE-ARD wins by far more than 3 nats,
  // and the kinked function, where Matérn-5/2 is kept.
  for (const bool se_data : {true, false}) {
    CAPTURE(se_data);
    const Dataset data = se_data ? smooth_se_sample(5) : kinked(3);
    const auto fit = [&](const std::string& yaml) {
      auto gp = make(yaml, 2);
      Rng rng(21);
      const FitReport rep = gp->fit(data, rng);
      REQUIRE(rep.ok);
      return std::make_tuple(as_gp(*gp).kernel_choice(), rep.objective, gp->hyperparameters());
    };
    const auto [auto_choice, auto_objective, auto_h] = fit("{type: gp}");
    const auto [list_choice, list_objective, list_h] =
        fit("{type: gp, kernel_candidates: [matern52_ard, se_ard], kernel_choice_margin: 3}");
    CHECK(auto_choice == (se_data ? 1u : 0u));
    CHECK(auto_choice == list_choice);
    CHECK(auto_objective == list_objective);
    check_same(auto_h, list_h);
    // kernel: matern52_ard given: a single kernel, never switched — on the SE sample it keeps Matérn's lower
    // objective where auto took SE-ARD's.
    const auto [m_choice, m_objective, m_h] = fit("{type: gp, kernel: matern52_ard}");
    CHECK(m_choice == 0u);
    if (se_data) CHECK(m_objective < auto_objective - 3.0);
    else CHECK(m_objective == auto_objective);
    CHECK(as_gp(*make("{type: gp, kernel: matern52_ard}", 2)).settings().kernel_candidates.empty());
  }
  // The resolved configuration names the choice, so a study reopened from it chooses again.
  const ResolvedComponent c = test::registry().resolve(Kind::Surrogate, ConfigNode::parse("{type: gp}", "<test>"));
  YAML::Emitter em;
  em << c.resolved();
  CHECK(YAML::Load(em.c_str())["kernel"]["type"].as<std::string>() == "auto");
  CHECK(as_gp(*make(em.c_str(), 2)).settings().kernel_candidates.size() == 2u);
  // `auto` is the gp's (and the vhgp's kernel_f, since session 17), not a kernel: anywhere else it is refused, naming it.
  for (const std::string yaml :
       {"{type: vhgp, kernel_g: auto}", "{type: gp, kernel: {type: sum, terms: [auto, white]}}"}) {
    CAPTURE(yaml);
    try {
      make(yaml, 2);
      FAIL("expected a ConfigError");
    } catch (const ConfigError& e) {
      CHECK(std::string(e.what()).find("'auto' is the gp's choice between kernels") != std::string::npos);
    }
  }
}

TEST_CASE("kernel_candidates: conditioned before any fit, the model says which candidate it used") {
  // Audit, session 48: a fit's hyperparameters (its chosen kernel se_ard) fed back with `varbo fit --no-optimize`
  // and kernel: auto were conditioned with Matérn-5/2 without a word.
  const Dataset data = smooth_se_sample(5);
  auto gp = make(kCandidates, 2);
  const FitReport first = gp->condition(data);
  REQUIRE(first.ok);
  CHECK(first.message.rfind("kernel matern52_ard (the first of the kernel candidates", 0) == 0);
  CHECK(first.message.find("kernel: se_ard") != std::string::npos);
  CHECK(as_gp(*gp).kernel_choice() == 0);
  // After a fit chose, conditioning keeps the choice and says nothing more.
  Rng rng(3);
  REQUIRE(gp->fit(data, rng).ok);
  CHECK(gp->condition(data).message.find("first of the kernel candidates") == std::string::npos);
  // A named kernel is no choice: nothing said.
  auto named = make("{type: gp, kernel: se_ard}", 2);
  CHECK(named->condition(data).message.find("kernel") == std::string::npos);
}
