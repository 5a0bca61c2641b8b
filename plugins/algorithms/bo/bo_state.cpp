// Exact snapshots of bo (varbo/state.hpp): a study continues from the state after its latest trial instead of
// replaying one model fit per finished trial. The observations come back through tell(); the state holds what
// they do not determine: the fit counter (refit_every), the latest model snapshot, and the states of the
// components that carry one from call to call (the surrogate's and the global probe's model's warm starts, a trust
// region, hit-and-run chains).
// The failure classifier is refitted at every ask, so it needs no state. The recommender (its cache, its own
// optimizer) is left out: recommendation() is called by `varbo run` and not by a replay, so its state is not a
// function of the trials; a restored bo recomputes a recommendation from the same data and model.
#include <fmt/format.h>

#include "bayesian_optimization.hpp"
#include "varbo/errors.hpp"

namespace varbo::bo {

namespace {
// Components other than the surrogate: saved when they offer a state, else taken to be stateless.
template <class T>
void save_if_stateful(StateMap& m, const char* key, const T* component) {
  if (const ComponentState* s = state_of(component)) m.put(key, s->save_state());
}
template <class T>
void restore_if_saved(const StateMap& m, const char* key, T* component) {
  if (!m.has(key)) return;
  ComponentState* s = state_of(component);
  if (!s) throw InputError(fmt::format("bo state: '{}' saved, but the component takes no state", key));
  s->restore_state(m.str(key));
}
}  // namespace

std::optional<std::string> BayesianOptimization::save_state() const {
  // Pending points change the next fit (fantasies): the study saves states only between serial steps.
  if (!pending_.empty()) return std::nullopt;
  const ComponentState* surrogate = state_of(surrogate_.get());
  if (!surrogate) return std::nullopt;  // every surrogate is warm-started: without its state, replay
  StateMap m;
  m.put_int("told", told_);
  m.put_int("fits", fits_);
  m.put("model_ready", model_ready_);
  m.put("feasibility_on", feasibility_on_);
  m.put("exclusion_threshold", exclusion_threshold_);
  m.put("snapshot", snapshot_);
  m.put_int("fresh_starts", fresh_starts_);
  m.put_int("fresh_trial", fresh_trial_);
  m.put_int("fresh_from", fresh_from_);
  m.put("refining", refining_);
  Vec starts(static_cast<Index>(attempt_starts_.size()));
  for (std::size_t i = 0; i < attempt_starts_.size(); ++i) starts(static_cast<Index>(i)) = static_cast<double>(attempt_starts_[i]);
  m.put("attempt_starts", starts);
  m.put_int("refine_lo", refine_lo_);
  m.put_int("refine_hi", refine_hi_);
  m.put_int("refine_from", refine_from_);
  if (refine_trial_ >= 0) m.put_int("refine_trial", refine_trial_);  // refine_backoff (absent before session 42)
  if (!blocked_.empty()) {  // failure_model.boundary_restart's blocked points, flattened (absent without any)
    Vec flat(static_cast<Index>(blocked_.size()) * dim_);
    for (std::size_t i = 0; i < blocked_.size(); ++i) flat.segment(static_cast<Index>(i) * dim_, dim_) = blocked_[i];
    m.put("blocked", flat);
  }
  if (!jumped_.empty()) {  // failure_model.boundary_jump's points, flattened (absent without any)
    Vec flat(static_cast<Index>(jumped_.size()) * dim_);
    for (std::size_t i = 0; i < jumped_.size(); ++i) flat.segment(static_cast<Index>(i) * dim_, dim_) = jumped_[i];
    m.put("jumped", flat);
  }
  if (!limited_trials_.empty()) {  // failure_model.feasible_region (absent without it)
    Vec limited(static_cast<Index>(limited_trials_.size()));
    for (std::size_t i = 0; i < limited_trials_.size(); ++i)
      limited(static_cast<Index>(i)) = static_cast<double>(limited_trials_[i]);
    m.put("limited_trials", limited);
  }
  if (follow_anchor_ >= 0) m.put_int("follow_anchor", follow_anchor_);  // follow_probe (absent without it)
  if (probe_trial_ >= 0) m.put_int("probe_trial", probe_trial_);  // global_probe (absent without it)
  if (failure_settings_.feasible_region != "off") m.put_int("region_counted_to", region_counted_to_);
  m.put("surrogate", surrogate->save_state());
  // The global probe's model is warm-started from its previous fit like the surrogate (absent before session 43: a
  // run restored between two probes fitted the second from scratch and probed 1e-4 away, test_attempt_probe.cpp).
  if (probe_model_) save_if_stateful(m, "probe_model", probe_model_.get());
  save_if_stateful(m, "region", region_.get());
  save_if_stateful(m, "design_sampler", design_sampler_.get());
  save_if_stateful(m, "acquisition_optimizer", optimizer_.get());
  return m.text();
}

void BayesianOptimization::restore_state(const std::string& text, const std::vector<Observation>& history) {
  const StateMap m = StateMap::parse(text, "bo state");
  if (told_ != 0) throw std::logic_error("bo: restore_state on an algorithm that was already told");
  tell(history);  // data, failures and the design counters, exactly as the saved run got them
  if (m.integer("told") != told_)
    throw InputError(fmt::format("bo state: saved after {} observations, {} given", m.integer("told"), told_));
  fits_ = static_cast<Index>(m.integer("fits"));
  model_ready_ = m.boolean("model_ready");
  feasibility_on_ = m.boolean("feasibility_on");
  exclusion_threshold_ = m.real("exclusion_threshold");
  snapshot_ = m.model_snapshot("snapshot");
  if (m.has("fresh_starts")) {  // absent in states saved before fresh starts existed (none happened then)
    fresh_starts_ = static_cast<int>(m.integer("fresh_starts"));
    fresh_trial_ = static_cast<Index>(m.integer("fresh_trial"));
    fresh_from_ = static_cast<Index>(m.integer("fresh_from"));
    refining_ = m.boolean("refining");
    if (m.has("attempt_starts")) {  // absent before refine_model existed
      attempt_starts_.clear();
      for (const double v : m.vec("attempt_starts")) attempt_starts_.push_back(static_cast<Index>(v));
      refine_lo_ = static_cast<Index>(m.integer("refine_lo"));
      refine_hi_ = static_cast<Index>(m.integer("refine_hi"));
      refine_from_ = static_cast<Index>(m.integer("refine_from"));
    }
    // Saved before session 42 inside a refinement: it began at most refine_last trials before the end.
    refine_trial_ = m.has("refine_trial") ? static_cast<Index>(m.integer("refine_trial"))
                    : refining_         ? std::max<Index>(0, budget_ - refine_last_)
                                        : -1;
    if (refine_trial_ < -1 || refine_trial_ > told_) throw InputError("bo state: 'refine_trial' is not an asked trial");
  }
  blocked_.clear();
  if (m.has("blocked")) {
    const Vec flat = m.vec("blocked");
    if (flat.size() % dim_ != 0) throw InputError("bo state: 'blocked' is not a list of points of the dimension");
    for (Index i = 0; i < flat.size() / dim_; ++i) blocked_.push_back(flat.segment(i * dim_, dim_));
  }
  jumped_.clear();
  if (m.has("jumped")) {
    const Vec flat = m.vec("jumped");
    if (flat.size() % dim_ != 0) throw InputError("bo state: 'jumped' is not a list of points of the dimension");
    for (Index i = 0; i < flat.size() / dim_; ++i) jumped_.push_back(flat.segment(i * dim_, dim_));
  }
  limited_trials_.clear();
  if (m.has("limited_trials"))
    for (const double v : m.vec("limited_trials")) limited_trials_.push_back(static_cast<Index>(v));
  follow_anchor_ = m.has("follow_anchor") ? static_cast<Index>(m.integer("follow_anchor")) : -1;
  if (follow_anchor_ < -1 || follow_anchor_ >= data_.size())
    throw InputError("bo state: 'follow_anchor' is not a successful observation");
  probe_trial_ = m.has("probe_trial") ? static_cast<Index>(m.integer("probe_trial")) : -1;
  // A state is also saved with the probe asked and its result not yet told (a study saves it with the suggestion).
  if (probe_trial_ < -1 || probe_trial_ > told_) throw InputError("bo state: 'probe_trial' is not an asked trial");
  region_counted_to_ = m.has("region_counted_to") ? static_cast<Index>(m.integer("region_counted_to")) : 0;
  ComponentState* surrogate = state_of(surrogate_.get());
  if (!surrogate) throw InputError("bo state: the surrogate takes no state");
  surrogate->restore_state(m.str("surrogate"));
  if (probe_model_) restore_if_saved(m, "probe_model", probe_model_.get());
  restore_if_saved(m, "region", region_.get());
  restore_if_saved(m, "design_sampler", design_sampler_.get());
  restore_if_saved(m, "acquisition_optimizer", optimizer_.get());
}

}  // namespace varbo::bo
