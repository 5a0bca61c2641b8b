// Hartmann-6 with held-out failure region 0 of session 37 (a box cutting x2 between the global minimiser and the
// rest of the box), seed 1, budget 100: a run that restarts after failures in its design. Shared by the tests of the
// rules that apply once a trial has failed (short_restarts, refine_last).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "study_helpers.hpp"
#include "varbo_test.hpp"

namespace varbo::test {

inline const std::string kHartmann6Box =
    "{shape: box, lower: [0.0, 0.186, 0.0, 0.0, 0.0, 0.0], upper: [1.0, 0.736, 1.0, 0.545, 1.0, 1.0]}";

using Rows = std::vector<std::vector<std::string>>;

/// trials.csv of `{type: bo, failure_model: failure_model}` on Hartmann-6, with the box as failure region or without;
/// `tag` names the run's folder (one tag per failure_model).
inline Rows run_hartmann6(const std::string& tag, bool region, const std::string& failure_model, int threads = 1) {
  RunOverrides ov;
  ov.output = temp_folder(tag + "_" + std::to_string(region) + "_" + std::to_string(threads));
  ov.threads = threads;
  const std::string yaml = std::string("task: {type: hartmann6") + (region ? ", failure_region: " + kHartmann6Box : "") +
                           "}\nbudget: 100\nseed: 1\nalgorithm: {type: bo" +
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

}  // namespace varbo::test
