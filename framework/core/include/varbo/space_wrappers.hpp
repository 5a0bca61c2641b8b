#pragma once
// What a search space changes in a model-based algorithm, as wrappers around any surrogate and any region, so
// that every surrogate (gp, vhgp, a plugin's) and every region (trust_region, confidence, box) respects the
// parameter types and the linear constraints without touching their math.
#include <memory>
#include <string>

#include "varbo/region.hpp"
#include "varbo/search_space.hpp"
#include "varbo/state.hpp"
#include "varbo/surrogate.hpp"

namespace varbo {

/// The surrogate seen through T(x) = SearchSpace::round_discrete(x) (Garrido-Merchán & Hernández-Lobato 2020,
/// section 3): the data and every prediction point are rounded to admissible integer values and one-hot
/// categories before the inner model sees them, so the prediction is constant between admissible values (its
/// gradient there is zero) and the kernel's distances are those between admissible points. Continuous
/// coordinates pass through unchanged, with the inner model's gradient.
class RoundedSurrogate final : public Surrogate, public ComponentState {
 public:
  RoundedSurrogate(std::unique_ptr<Surrogate> inner, SharedSpace space);
  /// A non-owning view (the acquisition model of an inner surrogate with an output transform).
  RoundedSurrogate(const Surrogate& inner, SharedSpace space);

  FitReport fit(const Dataset& data, Rng& rng) override;
  FitReport condition(const Dataset& data) override;
  Prediction predict(const Vec& x, bool with_gradient) const override;
  double signal_variance() const override { return target().signal_variance(); }
  Hyperparameters hyperparameters() const override { return target().hyperparameters(); }
  void set_hyperparameters(const Hyperparameters& values) override;
  std::vector<std::pair<std::string, Vec>> state() const override { return target().state(); }
  void set_state(const std::string& name, const Vec& value) override;
  bool ready() const override { return target().ready(); }
  const Surrogate& acquisition_model() const override;
  bool tests_noise_on_replicates() const override { return target().tests_noise_on_replicates(); }

  /// The inner surrogate's ComponentState (std::runtime_error when it offers none: the caller then replays).
  std::string save_state() const override;
  void restore_state(const std::string& state) override;

  const Surrogate& inner() const { return target(); }

 private:
  const Surrogate& target() const { return owned_ ? *owned_ : *view_; }
  Dataset rounded(const Dataset& data) const;
  void refresh_acquisition_view();

  std::unique_ptr<Surrogate> owned_;
  const Surrogate* view_ = nullptr;
  SharedSpace space_;
  std::unique_ptr<RoundedSurrogate> acquisition_view_;
};

/// A region seen in a typed space: its box widened so that the neighbouring integers and every category stay
/// reachable (SearchSpace::widen_for_discrete; a trust region shrunk below one integer's cell would round every
/// candidate to the same point), and intersected with the space's linear constraints (a polytope in encoded
/// coordinates): c(x) = min(inner c(x), min_j slack_j(x)), each slack a row's signed distance (b_j − a_j·x)/‖a_j‖,
/// so samplers, hit-and-run and constrained optimizers (SLSQP, COBYLA) keep to it.
class ConstrainedRegion final : public RegionConstraint, public ComponentState, public FreshStartRegion {
 public:
  ConstrainedRegion(std::unique_ptr<RegionConstraint> inner, SharedSpace space);
  void update(const Surrogate* model, const Dataset& data, Rng& rng) override;
  const Box& bounds() const override { return box_; }
  bool has_constraint() const override { return space_->has_constraints() || inner_->has_constraint(); }
  double constraint(const Vec& x, Vec* grad) const override;
  Mat seeds() const override;
  std::string state() const override { return inner_->state(); }
  std::string save_state() const override;
  void restore_state(const std::string& state) override;
  const RegionConstraint& inner() const { return *inner_; }
  /// Forwarded to the inner region (0 and nothing when it does not restart afresh).
  int fresh_starts() const override;
  void return_to_incumbent() override;

 private:
  void refresh() { box_ = space_->has_discrete() ? space_->widen_for_discrete(inner_->bounds()) : inner_->bounds(); }
  std::unique_ptr<RegionConstraint> inner_;
  SharedSpace space_;
  Box box_;
};

/// `surrogate` wrapped in RoundedSurrogate when the space has integer or categorical parameters.
std::unique_ptr<Surrogate> respect_types(std::unique_ptr<Surrogate> surrogate, const SharedSpace& space);
/// `region` wrapped in ConstrainedRegion when the space has integers, categories or constraints.
std::unique_ptr<RegionConstraint> respect_constraints(std::unique_ptr<RegionConstraint> region, const SharedSpace& space);

}  // namespace varbo
