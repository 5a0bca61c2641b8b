#include "given_parameters.hpp"

#include <algorithm>
#include <string>
#include <utility>
#include <vector>

namespace varbo::vhgp {

namespace {
/// The map a YAML must give for these names: indexed names `x[0..k-1]` as `x: [k values]`, keys with brackets
/// quoted (a flow map needs it): {lengthscale_f: [2 values], signal_std_f, ..., mu0} for ARD kernels.
std::string expected_map(const Hyperparameters& all) {
  std::vector<std::pair<std::string, int>> keys;  // base name, number of indexed values (0: a scalar)
  for (const auto& h : all) {
    const std::string& n = h.name;
    const std::size_t open = n.rfind('[');
    const bool indexed = n.back() == ']' && open != std::string::npos && open + 2 < n.size() &&
                         n.find_first_not_of("0123456789", open + 1) == n.size() - 1;
    const std::string base = indexed ? n.substr(0, open) : n;
    if (indexed && !keys.empty() && keys.back().first == base) ++keys.back().second;
    else keys.emplace_back(base, indexed ? 1 : 0);
  }
  std::string out;
  for (const auto& [base, count] : keys) {
    out += (out.empty() ? "{" : ", ") + (base.find('[') != std::string::npos ? "'" + base + "'" : base);
    if (count > 0) out += ": [" + std::to_string(count) + " values]";
  }
  return out + "}";
}
}  // namespace

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
                               " (expected " + expected_map(inner_->hyperparameters()) + ")");
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
