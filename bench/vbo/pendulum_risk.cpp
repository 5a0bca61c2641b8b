// The pendulum reproduction of Kuindersma 2013, section 5.2 / Fig. 4 (issue 3, benchmarks): after a VBO run
// of examples/vbo_pendulum.yaml, select the κ = +2 (risk-averse) and κ = −2 (risk-seeking) policies on the
// refitted model (eq. 20), evaluate each `episodes` times on the task with common random numbers (episode e
// draws the same τmax for both policies), and report cost mean/std, success rate and swing counts.
//   bench_vbo_pendulum RUN_DIR [episodes = 200] [seed = 1]
#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "swingup.hpp"
#include "varbo/errors.hpp"
#include "varbo/loader.hpp"
#include "varbo/run_folder.hpp"
#include "varbo/select.hpp"

using namespace varbo;

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s RUN_DIR [episodes=200] [seed=1]\n", argv[0]);
    return 2;
  }
  try {
    const std::string dir = argv[1];
    const int episodes = argc > 2 ? std::atoi(argv[2]) : 200;
    const std::uint64_t seed = argc > 3 ? std::strtoull(argv[3], nullptr, 10) : 1;
    Registry& registry = default_registry();
    const RunFolder run = load_run_folder(dir, registry);
    if (run.study.task.info->name != "pendulum_swingup") throw InputError(dir + ": not a pendulum_swingup run");
    auto model = make_run_surrogate(run, *run_surrogate_spec(run), registry, seed, true);
    const FitReport rep = fit_run_surrogate(*model, run, seed);
    BuildContext octx;
    octx.dim = 2;
    const auto opt = registry.create<Optimizer>("{type: multistart, candidates: 2000, polish: 8}", octx);
    const auto sel = select_policies(*model, run.domain, {2.0, -2.0}, *opt, Rng(seed).stream(0x5e1), run.data.X);

    // The task exactly as configured in the run (options of config.resolved.yaml).
    const Options& o = run.study.task.options;
    const tasks::SwingupSettings s = tasks::swingup_settings(o);

    std::printf("run %s: %lld trials, %s fit objective %.6g%s\n", dir.c_str(), static_cast<long long>(run.trials),
                run_surrogate_spec(run)->info->name.c_str(), rep.objective, rep.ok ? "" : " (FAILED)");
    std::printf("| policy | θ = [t1, t2] | predicted E | predicted s | cost mean | cost std | reaches upright | "
                "swings (2 / 3 / other) |\n|---|---|---|---|---|---|---|---|\n");
    const Rng episodes_rng = Rng(seed).stream(0xe915);
    for (const RiskSelection& r : sel) {
      if (!r.ok) {
        std::printf("| κ = %+g | no selection: %s |\n", r.kappa, r.message.c_str());
        continue;
      }
      double sum = 0, sum2 = 0;
      int reached = 0, two = 0, three = 0;
      for (int e = 0; e < episodes; ++e) {
        Rng rng = episodes_rng.stream(static_cast<std::uint64_t>(e));  // same τmax for both policies
        const double tau = s.tau_mean + s.tau_std * rng.normal();
        const tasks::SwingupResult res = tasks::simulate_swingup(r.theta[0], r.theta[1], tau, s);
        sum += res.cost;
        sum2 += res.cost * res.cost;
        reached += res.reached ? 1 : 0;
        two += (res.reached && res.swings == 2) ? 1 : 0;
        three += (res.reached && res.swings == 3) ? 1 : 0;
      }
      const double mean = sum / episodes;
      const double sd = std::sqrt(std::max(0.0, (sum2 - episodes * mean * mean) / (episodes - 1)));
      std::printf("| κ = %+g (%s) | [%.3f, %.3f] | %.5f | %.5f | %.5f | %.5f | %d / %d | %d / %d / %d |\n", r.kappa,
                  r.kappa > 0 ? "risk-averse" : "risk-seeking", r.theta[0], r.theta[1], r.mean, r.std, mean, sd,
                  reached, episodes, two, three, episodes - two - three);
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
