// Hartmann-3 with bench_failures' ball across the global valley (radius 0.415 at (0.45, 0.55, 0.55); the global
// minimiser (0.115, 0.556, 0.853) lies 0.037 outside it), budget 50: the scenario of the probes (global_probe,
// probe_every) and of follow_probe.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "bo_on_bowl.hpp"
#include "study_helpers.hpp"
#include "varbo_test.hpp"

namespace varbo::test {

inline const std::string kHartmann3Ball = "{shape: ball, center: [0.45, 0.55, 0.55], radius: 0.415}";

/// trials.csv of `algorithm` on Hartmann-3 (budget 50), with the ball as failure region or without; `tag` names the
/// run's folder (one tag per algorithm).
inline std::vector<std::vector<std::string>> run_hartmann3(const std::string& tag, const std::string& algorithm,
                                                           bool region, int threads = 1, std::uint64_t seed = 1) {
  const std::string yaml = std::string("task: {type: hartmann3") + (region ? ", failure_region: " + kHartmann3Ball : "") +
                           "}\nbudget: 50\nseed: " + std::to_string(seed) + "\nalgorithm: " + algorithm + "\n";
  RunOverrides ov;
  ov.output = temp_folder(tag + "_" + std::to_string(region) + "_" + std::to_string(threads) + "_" +
                          std::to_string(seed));
  ov.threads = threads;
  run_yaml(yaml, registry(), ov);
  return read_rows(*ov.output + "/trials.csv");
}

}  // namespace varbo::test
