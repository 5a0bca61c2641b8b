// Exact snapshot of a VHGP (varbo/state.hpp), as gp_state.cpp does for the GP: what the next fit warm-starts from
// (the fitted or given parameters, the last heteroscedastic and homoscedastic solutions), the full-fit counter and
// the noise-model choice, and the posterior as (data, scaling, model-unit parameters), rebuilt by the same
// deterministic VhgpPosterior::condition, so predictions after a restore are bit-for-bit those before.
#include "vhgp_surrogate.hpp"
#include "given_parameters.hpp"

#include <cstddef>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "varbo/errors.hpp"

namespace varbo::vhgp {

namespace {
// Empty vectors (e.g. log Λ of given hyperparameters) are left out and read back as empty.
void put_vec(StateMap& m, const std::string& key, const Vec& v) {
  if (v.size() > 0) m.put(key, v);
}
Vec get_vec(const StateMap& m, const std::string& key) { return m.has(key) ? m.vec(key) : Vec(); }
}  // namespace

std::string VhgpSurrogate::save_state() const {
  StateMap m;
  m.put_int("dim", dim_);
  if (!config_.kernel_f_candidates.empty()) {
    // kernel_f: auto — the kernel of f the values below belong to; by index, with the name to refuse a snapshot
    // of another candidate list (as gp_state.cpp).
    m.put_int("kernel_f_choice", static_cast<long long>(f_choice_));
    m.put("kernel_f_choice_name", config_.kernel_f_candidates[f_choice_].name);
  }
  const auto put_params = [&m](const std::string& prefix, const CostParams& c) {
    m.put(prefix, true);
    put_vec(m, prefix + "_theta_f", c.theta_f);
    put_vec(m, prefix + "_theta_g", c.theta_g);
    put_vec(m, prefix + "_log_lambda", c.log_lambda);
    m.put(prefix + "_mu0", c.mu0);
  };
  if (params_) put_params("params", *params_);
  if (heteroscedastic_) put_params("heteroscedastic", *heteroscedastic_);
  put_vec(m, "homoscedastic", homoscedastic_);
  m.put("homoscedastic_selected", homoscedastic_selected_);
  m.put_int("last_full_fit_n", last_full_fit_n_);
  m.put("bound", bound_);
  put_vec(m, "bound_gradient", bound_gradient_);
  m.put("scaling_mean", scaling_.mean);
  m.put("scaling_scale", scaling_.scale);
  if (posterior_ && posterior_data_) {
    m.put("posterior_params", posterior_params_);
    m.put("posterior_X", posterior_data_->X);
    m.put("posterior_y", posterior_data_->y);
  }
  // homoscedastic_member gp: the gp member's own exact snapshot (gp_state.cpp) and whether it is the model.
  if (gp_member_) {
    m.put("gp_selected", gp_selected_);
    if (gp_member_->ready()) m.put("gp_member", gp_member_->save_state());
  }
  return m.text();
}

void VhgpSurrogate::restore_state(const std::string& text) {
  const StateMap m = StateMap::parse(text, "vhgp state");
  if (m.integer("dim") != dim_) throw InputError("vhgp state: saved for dimension " + std::to_string(m.integer("dim")));
  // f's kernel first: the parameters and the posterior below are laid out for it.
  const std::vector<gp::KernelCandidate>& cands = config_.kernel_f_candidates;
  if (m.has("kernel_f_choice") != !cands.empty())
    throw InputError(cands.empty() ? "vhgp state: saved by a vhgp with kernel_f: auto; this vhgp has a single kernel_f"
                                   : "vhgp state: saved by a vhgp with a single kernel_f; this vhgp has kernel_f: auto");
  if (!cands.empty()) {
    const long long c = m.integer("kernel_f_choice");
    const std::string name = m.str("kernel_f_choice_name");
    if (c < 0 || static_cast<std::size_t>(c) >= cands.size() || cands[static_cast<std::size_t>(c)].name != name)
      throw InputError("vhgp state: the saved kernel_f choice '" + name + "' is not entry " + std::to_string(c) +
                       " of this vhgp's kernel_f candidates");
    use_f_kernel(static_cast<std::size_t>(c));
  }
  const auto get_params = [&m, this](const std::string& prefix) -> std::optional<CostParams> {
    if (!m.has(prefix)) return std::nullopt;
    CostParams c;
    c.theta_f = get_vec(m, prefix + "_theta_f");
    c.theta_g = get_vec(m, prefix + "_theta_g");
    c.log_lambda = get_vec(m, prefix + "_log_lambda");
    c.mu0 = m.real(prefix + "_mu0");
    if (c.theta_f.size() != f_form_->num_params() || c.theta_g.size() != g_form_->num_params())
      throw InputError("vhgp state: '" + prefix + "' was saved for other kernels (" + std::to_string(c.theta_f.size()) +
                       " and " + std::to_string(c.theta_g.size()) + " hyperparameters, these take " +
                       std::to_string(f_form_->num_params()) + " and " + std::to_string(g_form_->num_params()) + ")");
    return c;
  };
  posterior_.reset();
  posterior_data_.reset();
  posterior_params_ = Vec();
  params_ = get_params("params");
  lambda_fitted_ = true;  // a saved model's log Λ is a fit's (a batch then conditions on more points, in silence)
  heteroscedastic_ = get_params("heteroscedastic");
  homoscedastic_ = get_vec(m, "homoscedastic");
  homoscedastic_selected_ = m.boolean("homoscedastic_selected");
  last_full_fit_n_ = static_cast<Index>(m.integer("last_full_fit_n"));
  bound_ = m.real("bound");
  bound_gradient_ = get_vec(m, "bound_gradient");
  scaling_.mean = m.real("scaling_mean");
  scaling_.scale = m.real("scaling_scale");
  gp_selected_ = false;
  if (gp_member_ && m.has("gp_member")) {
    gp_member_->restore_state(m.str("gp_member"));
    gp_selected_ = m.has("gp_selected") && m.boolean("gp_selected");
  }
  if (!m.has("posterior_params")) return;
  Dataset data;
  data.X = m.mat("posterior_X");
  data.y = m.vec("posterior_y");
  const Vec p = m.vec("posterior_params");
  const Index n = data.y.size();
  if (data.X.rows() != n || data.X.cols() != dim_ || p.size() != n + f_form_->num_params() + g_form_->num_params() + 1)
    throw InputError("vhgp state: the posterior's data and parameters do not fit together (or the kernels differ)");
  // As condition_at: the same standardized targets and parameters give the same posterior.
  const Vec ys = (data.y.array() - scaling_.mean) / scaling_.scale;
  const VhgpBound bound(data.X, ys, config_.kernels);
  BoundValue value;
  auto post = std::make_shared<VhgpPosterior>(VhgpPosterior::condition(bound, bound.unpack(p), &value));
  if (!value.ok) throw InputError("vhgp state: the saved posterior cannot be rebuilt (" + value.error + ")");
  posterior_ = std::move(post);
  posterior_data_ = std::move(data);
  posterior_params_ = p;
}

std::string GivenParameters::save_state() const {
  const ComponentState* inner = state_of(inner_.get());
  if (!inner) throw std::logic_error("vhgp: the model wrapped by GivenParameters takes no state");
  StateMap m;
  m.put("used", used_);
  m.put("model", inner->save_state());
  return m.text();
}

void GivenParameters::restore_state(const std::string& text) {
  const StateMap m = StateMap::parse(text, "vhgp state");
  ComponentState* inner = state_of(inner_.get());
  if (!inner) throw std::logic_error("vhgp: the model wrapped by GivenParameters takes no state");
  used_ = m.boolean("used");
  inner->restore_state(m.str("model"));
}

}  // namespace varbo::vhgp
