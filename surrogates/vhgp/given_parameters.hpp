#pragma once
// What the YAML gave a `vhgp` (hyperparameters, log Λ) and the rule for conditioning on exactly that
// (issue 12, item 8). A model that is conditioned before it was ever fitted — `varbo fit --no-optimize` — has no
// fitted values to fall back on: every hyperparameter and one log Λ per data point must be given, or the bound
// would be evaluated at made-up defaults (lengthscales 0.3, log Λ = log ½) without a word. A fit, in contrast, uses
// the given values only as a start, so missing ones may be defaulted there.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "varbo/config.hpp"
#include "varbo/state.hpp"
#include "varbo/surrogate.hpp"

namespace varbo::vhgp {

/// Forwards everything to the wrapped model; refuses a condition() before any fit() or condition() unless the
/// parameters are complete. The checks throw ConfigError naming the YAML key (file:line:col) and the expected form.
class GivenParameters final : public Surrogate, public ComponentState {
 public:
  /// `missing`: hyperparameter names the YAML did not give (as hyperparameters() names them);
  /// `hyperparameters_node`, `log_lambda_node`: where the YAML gives (or would give) them, for messages;
  /// `log_lambda_size`: how many log Λ values it gave (none: nullopt).
  GivenParameters(std::unique_ptr<Surrogate> inner, std::vector<std::string> missing, ConfigNode hyperparameters_node,
                  ConfigNode log_lambda_node, std::optional<Index> log_lambda_size);

  FitReport fit(const Dataset& data, Rng& rng) override;
  FitReport condition(const Dataset& data) override;
  Prediction predict(const Vec& x, bool with_gradient) const override { return inner_->predict(x, with_gradient); }
  double signal_variance() const override { return inner_->signal_variance(); }
  Hyperparameters hyperparameters() const override { return inner_->hyperparameters(); }
  void set_hyperparameters(const Hyperparameters& values) override;
  std::vector<std::pair<std::string, Vec>> state() const override { return inner_->state(); }
  void set_state(const std::string& name, const Vec& value) override;
  bool ready() const override { return inner_->ready(); }
  /// Exact snapshot: whether the model was used yet, and the wrapped model's state (vhgp_state.cpp).
  std::string save_state() const override;
  void restore_state(const std::string& state) override;
  /// This wrapper, unless the wrapped model names another one: predictions are the same.
  const Surrogate& acquisition_model() const override {
    const Surrogate& m = inner_->acquisition_model();
    return &m == inner_.get() ? *this : m;
  }

 private:
  /// Throws unless the given parameters determine the model on `data` completely.
  void check_complete(const Dataset& data) const;

  std::unique_ptr<Surrogate> inner_;
  std::vector<std::string> missing_;
  ConfigNode hyperparameters_node_, log_lambda_node_;
  std::optional<Index> log_lambda_size_;
  bool used_ = false;  ///< fitted or conditioned once: from then on the model's own values stand
};

}  // namespace varbo::vhgp
