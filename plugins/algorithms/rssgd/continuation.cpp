#include "continuation.hpp"

#include <algorithm>

#include "varbo/numbers.hpp"

namespace varbo::rssgd {

LocalModelSpec Continuation::local_model(const Options* o, const Registry& registry) const {
  LocalModelSpec m;
  if (o) {
    // The run's own critic and ε (paper: ε = 3.5σ when not given).
    m.critic = o->component("critic");
    const double eps = o->real("epsilon");
    double sigma = o->real("sigma");
    if (o->is_set("sigma_diag"))
      for (double v : o->reals("sigma_diag")) sigma = std::max(sigma, v);
    m.radius = eps > 0 ? eps : 3.5 * sigma;
    m.min_points = o->integer("min_local_points");
  } else {
    // A run of another algorithm: a VHGP (it models the cost's variance, which r̃ needs) on the ball that rssgd's
    // default σ = 0.075 gives (ε = 3.5σ), with rssgd's default minimum of local points.
    m.critic = registry.resolve(Kind::Surrogate, ConfigNode::parse("{type: vhgp}", "<rescore default critic>"));
    m.radius = 0.2625;
    m.min_points = 3;
  }
  // SLSQP polish (paper: SQP) of quasi-random candidates inside the ball.
  m.optimizer = registry.resolve(
      Kind::Optimizer, ConfigNode::parse("{type: multistart, candidates: 500, polish: 5}", "<rescore default optimizer>"));
  return m;
}

void Continuation::continue_from(YAML::Node& algorithm, const std::string& history_csv, double kappa) const {
  algorithm.remove("phases");
  algorithm.remove("start");  // the continuation starts at the study's initial_point: the re-selected policy
  algorithm["kappa"] = yaml_scalar(kappa);  // "C" locale whatever the host's (numbers.hpp)
  algorithm["history"] = history_csv;
  algorithm["evaluate_initial"] = false;  // the history already holds the neighbourhood; every trial is a step
}

}  // namespace varbo::rssgd
