// Exact snapshot of a GP (varbo/state.hpp): what the next fit warm-starts from (the kernel's log-values with their
// given/fitted flags, the noise and mean), the full-fit counter, the chosen kernel_candidates entry, and the posterior as (data, log-parameters) —
// rebuilt by the same deterministic build(), so predictions after a restore are bit-for-bit those before.
#include "gp_surrogate.hpp"
#include "varbo/errors.hpp"

namespace varbo::gp {

std::string GpSurrogate::save_state() const {
  StateMap m;
  m.put_int("dim", dim_);
  m.put("kernel_log", kernel_log_);
  Vec known(static_cast<Index>(kernel_known_.size()));
  for (std::size_t j = 0; j < kernel_known_.size(); ++j) known(static_cast<Index>(j)) = kernel_known_[j] ? 1.0 : 0.0;
  m.put("kernel_known", known);
  m.put("log_noise_std", log_noise_std_);
  m.put("mean", mean_);
  m.put("noise_known", noise_known_);
  m.put("mean_fixed", mean_fixed_);
  m.put_int("last_full_fit_n", last_full_fit_n_);
  if (!settings_.kernel_candidates.empty()) {
    // By index, with the name to refuse a snapshot of another candidate list.
    m.put_int("kernel_choice", static_cast<long long>(choice_));
    m.put("kernel_choice_name", settings_.kernel_candidates[choice_].name);
  }
  if (posterior_ && data_) {
    m.put("posterior_params", posterior_->log_params);
    m.put("posterior_X", data_->X);
    m.put("posterior_y", data_->y);
  }
  return m.text();
}

void GpSurrogate::restore_state(const std::string& text) {
  const StateMap m = StateMap::parse(text, "gp state");
  const auto d = static_cast<Index>(m.integer("dim"));
  posterior_.reset();
  data_.reset();
  // The chosen kernel first: its form (and noise floor) is what the values below belong to.
  const std::vector<KernelCandidate>& cands = settings_.kernel_candidates;
  if (m.has("kernel_choice") != !cands.empty())
    throw InputError(cands.empty() ? "gp state: saved by a gp with kernel_candidates; this gp has a single kernel"
                                   : "gp state: saved by a gp with a single kernel; this gp has kernel_candidates");
  if (!cands.empty()) {
    const long long c = m.integer("kernel_choice");
    const std::string name = m.str("kernel_choice_name");
    if (c < 0 || static_cast<std::size_t>(c) >= cands.size() || cands[static_cast<std::size_t>(c)].name != name)
      throw InputError("gp state: the saved kernel choice '" + name + "' is not entry " + std::to_string(c) +
                       " of this gp's kernel_candidates");
    select_kernel(static_cast<std::size_t>(c));
  }
  ensure_dim(d);  // the kernel's form for this dimension; its values come next
  const Vec log = m.vec("kernel_log"), known = m.vec("kernel_known");
  if (log.size() != kernel_log_.size() || known.size() != kernel_log_.size())
    throw InputError("gp state: the saved kernel values do not fit this gp's kernel");
  kernel_log_ = log;
  for (Index j = 0; j < known.size(); ++j) kernel_known_[static_cast<std::size_t>(j)] = known(j) != 0.0;
  log_noise_std_ = m.real("log_noise_std");
  mean_ = m.real("mean");
  noise_known_ = m.boolean("noise_known");
  mean_fixed_ = m.boolean("mean_fixed");
  last_full_fit_n_ = static_cast<Index>(m.integer("last_full_fit_n"));
  if (!m.has("posterior_params")) return;
  Dataset data;
  data.X = m.mat("posterior_X");
  data.y = m.vec("posterior_y");
  const Vec p = m.vec("posterior_params");
  if (data.X.rows() != data.y.size() || data.X.cols() != d || p.size() != kernel_log_.size() + 1)
    throw InputError("gp state: the posterior's data and parameters do not fit together");
  auto post = build(data, standardization(data.y), p);
  if (!post) throw InputError("gp state: the saved posterior cannot be rebuilt (Cholesky failed)");
  posterior_ = std::move(post);
  data_ = std::move(data);
}

}  // namespace varbo::gp
