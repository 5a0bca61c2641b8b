// Exact snapshot of RSSGD (varbo/state.hpp): θ, the perturbations handed out and not yet told, the step
// counters (random-stream positions and the κ schedule), a κ set during learning, the latest model snapshot and
// the critic's state (its warm start). The data come back through the history, without re-running updates.
#include <fmt/format.h>

#include <cmath>

#include "rssgd.hpp"
#include "varbo/errors.hpp"

namespace varbo::rssgd {

std::optional<std::string> Rssgd::save_state() const {
  const ComponentState* critic = state_of(critic_.get());
  if (!critic) return std::nullopt;
  StateMap m;
  m.put("theta", theta_);
  std::vector<Vec> pending;
  Vec initial(static_cast<Index>(pending_.size()));
  for (std::size_t i = 0; i < pending_.size(); ++i) {
    pending.push_back(pending_[i].x);
    initial[static_cast<Index>(i)] = pending_[i].initial;
  }
  m.put("pending_x", pending);
  m.put("pending_initial", initial);
  m.put("asked_initial", asked_initial_);
  m.put_int("perturbations", perturbations_);
  m.put_int("steps", steps_);
  m.put_int("updates", updates_);
  m.put("critic_ready", critic_ready_);
  m.put("has_kappa_override", kappa_override_.has_value());
  m.put("kappa_override", kappa_override_.value_or(0.0));
  m.put_int("kappa_override_from", kappa_override_from_);
  m.put("has_snapshot", has_snapshot_);
  m.put("snapshot", snapshot_);
  m.put_int("data_size", data_.size());
  m.put("critic", critic->save_state());
  return m.text();
}

void Rssgd::restore_state(const std::string& text, const std::vector<Observation>& history) {
  const StateMap m = StateMap::parse(text, "rssgd state");
  // The data as tell() collects them (step (c) of Algorithm 3), without the updates.
  for (const Observation& o : history)
    if (o.ok && std::isfinite(o.cost) && o.x.size() == theta_.size()) data_.add(o.x, o.cost);
  if (m.integer("data_size") != data_.size())
    throw InputError(fmt::format("rssgd state: saved with {} data points, the history gives {}",
                                 m.integer("data_size"), data_.size()));
  const Vec theta = m.vec("theta");
  if (theta.size() != theta_.size()) throw InputError("rssgd state: θ has the wrong dimension");
  theta_ = theta;
  const std::vector<Vec> pending = m.rows("pending_x");
  const Vec initial = m.vec("pending_initial");
  if (static_cast<Index>(pending.size()) != initial.size()) throw InputError("rssgd state: inconsistent pending list");
  pending_.clear();
  for (std::size_t i = 0; i < pending.size(); ++i) pending_.push_back({pending[i], initial[static_cast<Index>(i)] != 0});
  asked_initial_ = m.boolean("asked_initial");
  perturbations_ = static_cast<Index>(m.integer("perturbations"));
  steps_ = static_cast<Index>(m.integer("steps"));
  updates_ = static_cast<Index>(m.integer("updates"));
  critic_ready_ = m.boolean("critic_ready");
  if (m.boolean("has_kappa_override")) kappa_override_ = m.real("kappa_override");
  else kappa_override_.reset();
  kappa_override_from_ = static_cast<Index>(m.integer("kappa_override_from"));
  has_snapshot_ = m.boolean("has_snapshot");
  snapshot_ = m.model_snapshot("snapshot");
  ComponentState* critic = state_of(critic_.get());
  if (!critic) throw InputError("rssgd state: the critic takes no state");
  critic->restore_state(m.str("critic"));
}

}  // namespace varbo::rssgd
