#include "given_parameters.hpp"

#include <algorithm>

namespace varbo::vhgp {

GivenParameters::GivenParameters(std::unique_ptr<Surrogate> inner, std::vector<std::string> missing,
                                 ConfigNode hyperparameters_node, ConfigNode log_lambda_node,
                                 std::optional<Index> log_lambda_size)
    : inner_(std::move(inner)),
      missing_(std::move(missing)),
      hyperparameters_node_(std::move(hyperparameters_node)),
      log_lambda_node_(std::move(log_lambda_node)),
      log_lambda_size_(log_lambda_size) {}

void GivenParameters::check_complete(const Dataset& data) const {
  const std::string why = "the vhgp is conditioned without a fit (varbo fit --no-optimize), so ";
  if (!missing_.empty())
    hyperparameters_node_.fail(why + "every hyperparameter must be given; missing: " + join(missing_) +
                               " (expected {lengthscale_f: [" + std::to_string(data.dim()) +
                               " values], signal_std_f, lengthscale_g: [" + std::to_string(data.dim()) +
                               " values], signal_std_g, mu0})");
  const std::string expected = "expected " + std::to_string(data.size()) + " values (one per data point)";
  if (!log_lambda_size_) log_lambda_node_.fail(why + "log_lambda must be given: " + expected);
  if (*log_lambda_size_ != data.size())
    log_lambda_node_.fail(why + expected + ", got " + std::to_string(*log_lambda_size_));
}

FitReport GivenParameters::fit(const Dataset& data, Rng& rng) {
  used_ = true;  // a fit starts from the given values and defaults the rest (documented)
  return inner_->fit(data, rng);
}

FitReport GivenParameters::condition(const Dataset& data) {
  if (!used_) check_complete(data);
  used_ = true;
  return inner_->condition(data);
}

void GivenParameters::set_hyperparameters(const Hyperparameters& values) {
  inner_->set_hyperparameters(values);
  // A scalar `lengthscale_f` sets every lengthscale_f[i].
  std::erase_if(missing_, [&](const std::string& name) {
    return std::any_of(values.begin(), values.end(), [&](const Hyperparameter& h) {
      return h.name == name || name.rfind(h.name + "[", 0) == 0;
    });
  });
}

void GivenParameters::set_state(const std::string& name, const Vec& value) {
  inner_->set_state(name, value);
  if (name == "log_lambda") log_lambda_size_ = value.size();
}

}  // namespace varbo::vhgp
