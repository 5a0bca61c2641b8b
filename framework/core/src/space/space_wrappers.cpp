// RoundedSurrogate and ConstrainedRegion (varbo/space_wrappers.hpp).
#include "varbo/space_wrappers.hpp"

#include <stdexcept>

#include "varbo/errors.hpp"

namespace varbo {

RoundedSurrogate::RoundedSurrogate(std::unique_ptr<Surrogate> inner, SharedSpace space)
    : owned_(std::move(inner)), space_(std::move(space)) {
  if (!owned_ || !space_) throw std::invalid_argument("RoundedSurrogate: null surrogate or space");
}

RoundedSurrogate::RoundedSurrogate(const Surrogate& inner, SharedSpace space) : view_(&inner), space_(std::move(space)) {}

Dataset RoundedSurrogate::rounded(const Dataset& data) const {
  Dataset out = data;
  for (Index i = 0; i < out.X.rows(); ++i) out.X.row(i) = space_->round_discrete(data.X.row(i).transpose()).transpose();
  return out;
}

void RoundedSurrogate::refresh_acquisition_view() {
  const Surrogate& a = target().acquisition_model();
  if (&a == &target()) acquisition_view_.reset();
  else if (!acquisition_view_ || &acquisition_view_->inner() != &a) acquisition_view_ = std::make_unique<RoundedSurrogate>(a, space_);
}

FitReport RoundedSurrogate::fit(const Dataset& data, Rng& rng) {
  if (!owned_) throw std::logic_error("RoundedSurrogate: a view cannot be fitted");
  FitReport r = owned_->fit(rounded(data), rng);
  refresh_acquisition_view();
  return r;
}

FitReport RoundedSurrogate::condition(const Dataset& data) {
  if (!owned_) throw std::logic_error("RoundedSurrogate: a view cannot be conditioned");
  FitReport r = owned_->condition(rounded(data));
  refresh_acquisition_view();
  return r;
}

Prediction RoundedSurrogate::predict(const Vec& x, bool with_gradient) const {
  Vec t = space_->round_discrete(x);
  // A rounded point outside the constraints is scored where it will be evaluated, its repaired point
  // (SearchSpace::admissible). Scored at the rounded point, x = 0.5, n = 6.6 under "x + n <= 7.2" stood for n = 7
  // while the suggestion became n = 6: bo proposed the same repaired point for 23 of 24 trials and lost to random
  // (audit, session 47). The continuous coordinates' derivative is then the model's at the repaired point.
  if (space_->has_constraints() && !space_->satisfies_constraints(t)) t = space_->admissible(x);
  Prediction p = target().predict(t, with_gradient);
  if (with_gradient && p.has_gradient()) {
    // T is piecewise constant in the integer and categorical coordinates: the derivative there is zero
    // (almost everywhere), and the identity in the continuous ones.
    for (Index k = 0; k < x.size(); ++k) {
      if (!space_->is_discrete_coordinate(k)) continue;
      for (Vec* g : {&p.d_mean, &p.d_latent_var, &p.d_log_noise_mean, &p.d_log_noise_var})
        if (g->size() == x.size()) (*g)[k] = 0;
    }
  }
  return p;
}

void RoundedSurrogate::set_hyperparameters(const Hyperparameters& values) {
  if (!owned_) throw std::logic_error("RoundedSurrogate: a view is read-only");
  owned_->set_hyperparameters(values);
  refresh_acquisition_view();
}

void RoundedSurrogate::set_state(const std::string& name, const Vec& value) {
  if (!owned_) throw std::logic_error("RoundedSurrogate: a view is read-only");
  owned_->set_state(name, value);
}

const Surrogate& RoundedSurrogate::acquisition_model() const {
  return acquisition_view_ ? static_cast<const Surrogate&>(*acquisition_view_) : *this;
}

std::string RoundedSurrogate::save_state() const {
  const ComponentState* s = state_of(&target());
  if (!s) throw std::runtime_error("the surrogate offers no state");
  return s->save_state();
}

void RoundedSurrogate::restore_state(const std::string& state) {
  ComponentState* s = owned_ ? state_of(owned_.get()) : nullptr;
  if (!s) throw InputError("the surrogate takes no state");
  s->restore_state(state);
  refresh_acquisition_view();
}

ConstrainedRegion::ConstrainedRegion(std::unique_ptr<RegionConstraint> inner, SharedSpace space)
    : inner_(std::move(inner)), space_(std::move(space)) {
  if (!inner_ || !space_) throw std::invalid_argument("ConstrainedRegion: null region or space");
  refresh();
}

void ConstrainedRegion::update(const Surrogate* model, const Dataset& data, Rng& rng) {
  inner_->update(model, data, rng);
  refresh();
}

double ConstrainedRegion::constraint(const Vec& x, Vec* grad) const {
  if (!space_->has_constraints()) return inner_->constraint(x, grad);
  Vec g;
  const double c = space_->constraint_slack(x, grad ? &g : nullptr);
  if (!inner_->has_constraint()) {
    if (grad) *grad = g;
    return c;
  }
  Vec gi;
  const double ci = inner_->constraint(x, grad ? &gi : nullptr);
  if (grad) *grad = ci < c ? gi : g;
  return std::min(c, ci);
}

Mat ConstrainedRegion::seeds() const {
  const Mat s = inner_->seeds();
  Mat out(s.rows(), s.cols());
  Index n = 0;
  for (Index i = 0; i < s.rows(); ++i)
    if (!space_->has_constraints() || space_->constraint_slack(s.row(i).transpose(), nullptr) >= 0) out.row(n++) = s.row(i);
  return out.topRows(n);
}

int ConstrainedRegion::fresh_starts() const {
  const auto* f = dynamic_cast<const FreshStartRegion*>(inner_.get());
  return f ? f->fresh_starts() : 0;
}

void ConstrainedRegion::return_to_incumbent() {
  if (auto* f = dynamic_cast<FreshStartRegion*>(inner_.get())) f->return_to_incumbent();
}

std::string ConstrainedRegion::save_state() const {
  const ComponentState* s = state_of(inner_.get());
  return s ? s->save_state() : std::string();
}

void ConstrainedRegion::restore_state(const std::string& state) {
  if (ComponentState* s = state_of(inner_.get())) s->restore_state(state);
  refresh();
}

std::unique_ptr<Surrogate> respect_types(std::unique_ptr<Surrogate> surrogate, const SharedSpace& space) {
  if (!space || !space->has_discrete()) return surrogate;
  return std::make_unique<RoundedSurrogate>(std::move(surrogate), space);
}

std::unique_ptr<RegionConstraint> respect_constraints(std::unique_ptr<RegionConstraint> region,
                                                      const SharedSpace& space) {
  if (!space || !(space->has_constraints() || space->has_discrete())) return region;
  return std::make_unique<ConstrainedRegion>(std::move(region), space);
}

}  // namespace varbo
