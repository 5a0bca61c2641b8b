// Exact snapshot of a GP (varbo/state.hpp): what the next fit warm-starts from (log-parameters and flags), the
// full-fit counter, and the posterior as (data, log-parameters) — rebuilt by the same deterministic build(),
// so predictions after a restore are bit-for-bit those before.
#include "gp_surrogate.hpp"
#include "varbo/errors.hpp"

namespace varbo::gp {

std::string GpSurrogate::save_state() const {
  StateMap m;
  m.put("log_lengthscale", log_lengthscale_);
  m.put("log_signal_std", log_signal_std_);
  m.put("log_noise_std", log_noise_std_);
  m.put("mean", mean_);
  m.put("signal_known", signal_known_);
  m.put("noise_known", noise_known_);
  m.put("mean_fixed", mean_fixed_);
  m.put_int("last_full_fit_n", last_full_fit_n_);
  if (posterior_ && data_) {
    m.put("posterior_params", posterior_->log_params);
    m.put("posterior_X", data_->X);
    m.put("posterior_y", data_->y);
  }
  return m.text();
}

void GpSurrogate::restore_state(const std::string& text) {
  const StateMap m = StateMap::parse(text, "gp state");
  log_lengthscale_ = m.vec("log_lengthscale");
  dim_ = log_lengthscale_.size();
  log_signal_std_ = m.real("log_signal_std");
  log_noise_std_ = m.real("log_noise_std");
  mean_ = m.real("mean");
  signal_known_ = m.boolean("signal_known");
  noise_known_ = m.boolean("noise_known");
  mean_fixed_ = m.boolean("mean_fixed");
  last_full_fit_n_ = static_cast<Index>(m.integer("last_full_fit_n"));
  posterior_.reset();
  data_.reset();
  if (!m.has("posterior_params")) return;
  Dataset data;
  data.X = m.mat("posterior_X");
  data.y = m.vec("posterior_y");
  const Vec p = m.vec("posterior_params");
  if (data.X.rows() != data.y.size() || p.size() != data.X.cols() + 2)
    throw InputError("gp state: the posterior's data and parameters do not fit together");
  auto post = build(data, standardization(data.y), p);
  if (!post) throw InputError("gp state: the saved posterior cannot be rebuilt (Cholesky failed)");
  posterior_ = std::move(post);
  data_ = std::move(data);
}

}  // namespace varbo::gp
