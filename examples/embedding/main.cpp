// Embedding varbo in a program that evaluates trials itself (a ROS node, a lab script): a durable study,
// 10 ask/tell cycles on an in-program cost, then the best trial and a risk-averse selection.
// Build against the installed SDK: cmake -S examples/embedding -B build-embed -DCMAKE_PREFIX_PATH=<prefix>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "varbo/study_api.hpp"

namespace {
// The study: the task gives the domain (branin's box here; a real robot would use its own parameters), the
// algorithm and the seed fix every suggestion.
const char* kStudy = R"(
task: {type: branin}
budget: 10
seed: 7
algorithm:
  type: bo
  initial_points: 4
  batch_strategy: kriging_believer
)";

// Stand-in for a trial on hardware: a smooth cost with a minimum at (1, 4).
double run_trial(const varbo::Vec& theta) { return std::pow(theta[0] - 1.0, 2) + 0.1 * std::pow(theta[1] - 4.0, 2); }
}  // namespace

int main() {
  const std::string file = "embedding_example.db";
  std::filesystem::remove(file);  // a fresh study each run of the example; a real program would Study::open it
  try {
    varbo::Study study = varbo::Study::create_from_yaml(file, kStudy, "embedded study");
    for (int i = 0; i < 10; ++i) {
      const std::vector<varbo::TrialRecord> trials = study.ask(1);
      if (trials.empty()) break;  // the budget is used: by finished trials, or by pending ones (then abandon them)
      const varbo::TrialRecord& t = trials.front();
      const double cost = run_trial(t.theta);
      study.tell(t.id, cost, {{"distance", cost}});
      std::printf("trial %lld: theta = (%.4f, %.4f)  cost %.5f\n", static_cast<long long>(t.id), t.theta[0],
                  t.theta[1], cost);
    }
    const auto best = study.best();
    if (!best) return 1;
    std::printf("best: trial %lld, cost %.5f at (%.4f, %.4f)\n", static_cast<long long>(best->id), best->cost,
                best->theta[0], best->theta[1]);
    if (const auto sel = study.select(1.0))
      std::printf("select(kappa=1): trial %lld, mean %.5f, std %.5f\n", static_cast<long long>(sel->trial_id),
                  sel->mean, sel->std);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
  return 0;
}
