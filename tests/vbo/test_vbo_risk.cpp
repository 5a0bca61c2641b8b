// Issue 3's statistical test (label `long`): on the 1-D synthetic task, after the example's budget
// (examples/vbo_synthetic.yaml: 10 random + 10 EI on a VHGP), CB with κ = +1.5 picks the low-variance minimum
// (θ = 0.25) and κ = −1.5 the high-variance one (θ = 0.75), for at least 8 of 10 seeds (Kuindersma 2013,
// section 5.1, Fig. 2(d)).
#include <cmath>
#include <cstdio>

#include "study_helpers.hpp"
#include "varbo/run_folder.hpp"
#include "varbo/select.hpp"
#include "varbo_test.hpp"

using namespace varbo;

TEST_CASE("VBO on two_minima_1d: kappa = +1.5 / -1.5 pick the low / high variance minimum in >= 8 of 10 seeds") {
  Registry& registry = test::registry();
  const ConfigNode root = ConfigNode::load_file(test::source_path("examples/vbo_synthetic.yaml"));
  const StudyConfig study = parse_study(root, registry);
  BuildContext octx;
  octx.dim = 1;
  // The default optimizer of `varbo select`.
  const auto optimizer = registry.create<Optimizer>("{type: multistart, candidates: 2000, polish: 8}", octx);
  int both = 0;
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    RunOverrides ov;
    ov.seed = seed;
    ov.output = test::temp_folder("vbo_risk_" + std::to_string(seed));
    ov.progress = false;
    run_study(study, registry, ov);
    const RunFolder run = load_run_folder(*ov.output, registry);
    REQUIRE(run.data.size() == 20);
    auto model = make_run_surrogate(run, *run_surrogate_spec(run), registry, 1, true);
    fit_run_surrogate(*model, run, 1);
    const auto sel = select_policies(*model, run.domain, {1.5, -1.5}, *optimizer, Rng(1).stream(0x5e1), run.data.X);
    REQUIRE(sel.size() == 2);
    // Within 0.1 of the minimum: inside its basin, well away from the other one (basins split at 0.5).
    const bool averse_ok = sel[0].ok && std::abs(sel[0].theta[0] - 0.25) < 0.1;
    const bool seeking_ok = sel[1].ok && std::abs(sel[1].theta[0] - 0.75) < 0.1;
    both += (averse_ok && seeking_ok) ? 1 : 0;
    // Diagnostics: the fitted log-noise GP at the two minima against the truth log(0.0325²) = −6.85 and
    // log(0.1325²) = −4.04, the fitted means there, and how many trials landed in each basin.
    const Prediction p25 = model->predict(Vec::Constant(1, 0.25), false);
    const Prediction p75 = model->predict(Vec::Constant(1, 0.75), false);
    const Index left = (run.data.X.col(0).array() < 0.5).count();
    std::printf("         mu*(0.25) %.2f s2* %.2f mean %.4f | mu*(0.75) %.2f s2* %.2f mean %.4f | trials %lld left, %lld right\n",
                p25.log_noise_mean, p25.log_noise_var, p25.mean, p75.log_noise_mean, p75.log_noise_var, p75.mean,
                static_cast<long long>(left), static_cast<long long>(run.data.size() - left));
    std::printf("seed %2llu: kappa +1.5 -> theta %.4f (E %.4f, s %.4f) %s | kappa -1.5 -> theta %.4f (E %.4f, s %.4f) %s\n",
                static_cast<unsigned long long>(seed), sel[0].theta[0], sel[0].mean, sel[0].std,
                averse_ok ? "ok" : "MISS", sel[1].theta[0], sel[1].mean, sel[1].std, seeking_ok ? "ok" : "MISS");
  }
  std::printf("both selections right in %d of 10 seeds (required: 8)\n", both);
  CHECK(both >= 8);
}
