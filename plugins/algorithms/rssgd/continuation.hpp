#pragma once
// rssgd's offer to continue a finished run offline (varbo/continuation.hpp; Kuindersma 2013, section 5.4.2):
// its critic and ε-ball as the local model, and an rssgd block that goes on from the re-scored trials.
#include "varbo/continuation.hpp"

namespace varbo::rssgd {

class Continuation final : public RunContinuation {
 public:
  LocalModelSpec local_model(const Options* run_options, const Registry& registry) const override;
  void continue_from(YAML::Node& algorithm, const std::string& history_csv, double kappa) const override;
};

}  // namespace varbo::rssgd
