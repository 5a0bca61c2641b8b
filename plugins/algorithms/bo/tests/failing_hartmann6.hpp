// Hartmann-6 with held-out failure region 0 of session 37 (a box cutting x2 between the global minimiser and the
// rest of the box), seed 1, budget 100: a run that restarts after failures in its design. Shared by the tests of the
// rules that apply once a trial has failed (short_restarts, refine_last); other regions and seeds for the final
// refinement's rules (refine_backoff, refine_waits: held-out ball 5).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "bo_on_bowl.hpp"
#include "study_helpers.hpp"
#include "varbo_test.hpp"

namespace varbo::test {

inline const std::string kHartmann6Box =
    "{shape: box, lower: [0.0, 0.186, 0.0, 0.0, 0.0, 0.0], upper: [1.0, 0.736, 1.0, 0.545, 1.0, 1.0]}";
/// Held-out region 5 of session 37: a ball of radius 0.871 that leaves the global minimiser 0.037 outside it and
/// covers part of the local minimum's basin (−3.20), whose feasible best lies at the ball's face.
inline const std::string kHartmann6Ball5 =
    "{shape: ball, center: [0.274, 0.567, 0.919, 0.938, 0.208, 0.649], radius: 0.871}";

using Rows = std::vector<std::vector<std::string>>;

/// The index of trials.csv's column `name` (required to exist).
inline std::size_t column(const Rows& rows, const char* name) {
  const int c = column_of(rows[0], name);
  REQUIRE(c >= 0);
  return static_cast<std::size_t>(c);
}

/// trials.csv of `{type: bo, failure_model: failure_model}` on Hartmann-6, with `failure_region` (the box by
/// default) or without; `tag` names the run's folder (one tag per failure_model and region).
inline Rows run_hartmann6(const std::string& tag, bool region, const std::string& failure_model, int threads = 1,
                          std::uint64_t seed = 1, const std::string& failure_region = kHartmann6Box) {
  RunOverrides ov;
  ov.output = temp_folder(tag + "_" + std::to_string(region) + "_" + std::to_string(threads) + "_" +
                          std::to_string(seed));
  ov.threads = threads;
  const std::string yaml = std::string("task: {type: hartmann6") + (region ? ", failure_region: " + failure_region : "") +
                           "}\nbudget: 100\nseed: " + std::to_string(seed) + "\nalgorithm: {type: bo" +
                           (failure_model.empty() ? "" : ", failure_model: " + failure_model) + "}\n";
  run_yaml(yaml, registry(), ov);
  return read_rows(*ov.output + "/trials.csv");
}

/// The same θ in every row (the rows' text, as written).
inline bool same_thetas(const Rows& a, const Rows& b) {
  if (a.size() != b.size()) return false;
  const auto x1 = static_cast<std::size_t>(column_of(a[0], "x1"));
  for (std::size_t r = 1; r < a.size(); ++r)
    for (std::size_t d = 0; d < 6; ++d)
      if (a[r][x1 + d] != b[r][x1 + d]) return false;
  return true;
}

/// The plain default bo on that task (seed 1, budget 100; or another region and seed), driven by ask and tell: the
/// tests that save and restore it.
struct FailingHartmann6Bo {
  explicit FailingHartmann6Bo(const std::string& failure_region = kHartmann6Box, std::uint64_t seed = 1)
      : ctx(bo_context(6, 100, seed)),
        observe("{type: hartmann6, failure_region: " + failure_region + "}", ctx),
        bo(registry().create<Algorithm>("{type: bo}", ctx)) {}
  BuildContext ctx;
  TaskObserver observe;
  std::unique_ptr<Algorithm> bo;
  std::vector<Observation> told;  ///< every observation told so far

  /// Asks one trial and tells its observation.
  Suggestion step() {
    const Suggestion s = bo->ask(1).front();
    const Observation o = observe(s.x);
    bo->tell({o});
    told.push_back(o);
    return s;
  }
  /// The state saved now, and the observations told before it (what restore_state takes).
  struct Saved {
    std::string state;
    std::vector<Observation> told;
  };
  Saved save() const { return {*dynamic_cast<const AlgorithmState&>(*bo).save_state(), told}; }
  /// A bo restored from `saved` asks exactly `later` (test::check_continues_as).
  void check_continues_as(const Saved& saved, const std::vector<Suggestion>& later) const {
    test::check_continues_as("{type: bo}", ctx, saved.state, saved.told, later, observe);
  }
};

}  // namespace varbo::test
