#pragma once
// Writes a run folder incrementally: every row is flushed when it happens, summary.json is replaced
// atomically, so an interrupted run loses nothing already recorded.
#include <fstream>
#include <string>
#include <vector>

#include "varbo/algorithm.hpp"
#include "varbo/study.hpp"
#include "varbo/task.hpp"

namespace varbo {

struct TrialRow {
  Index index = 0;
  std::string phase;
  Vec theta;  ///< user units
  Evaluation evaluation;
  double fit_seconds = 0, acquisition_seconds = 0, evaluation_seconds = 0;
};

class RunWriter {
 public:
  RunWriter(const std::string& folder, const StudyConfig& study, const Domain& domain,
            std::vector<std::string> component_names);
  void trial(const TrialRow& row);
  void model(const ModelSnapshot& snapshot);
  void summary(const RunSummary& summary, const Domain& domain, const std::optional<Optimum>& optimum);
  const std::string& folder() const { return folder_; }

 private:
  std::string folder_;
  std::vector<std::string> components_;
  std::ofstream trials_, model_;
  bool warned_extra_ = false;
};

}  // namespace varbo
