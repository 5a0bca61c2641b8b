#include "vhgp_params.hpp"

#include <stdexcept>
#include <string>

namespace varbo::vhgp {

Vec VhgpParams::pack() const {
  Vec v(size());
  v << log_lambda, theta_f, theta_g, mu0;
  return v;
}

VhgpParams VhgpParams::unpack(const Vec& v, Index n, Index num_f, Index num_g) {
  if (v.size() != n + num_f + num_g + 1)
    throw std::invalid_argument("VhgpParams::unpack: expected " + std::to_string(n + num_f + num_g + 1) +
                                " values, got " + std::to_string(v.size()));
  VhgpParams p;
  p.log_lambda = v.head(n);
  p.theta_f = v.segment(n, num_f);
  p.theta_g = v.segment(n + num_f, num_g);
  p.mu0 = v(v.size() - 1);
  return p;
}

Vec VhgpGradient::pack() const {
  Vec v(log_lambda.size() + theta_f.size() + theta_g.size() + 1);
  v << log_lambda, theta_f, theta_g, mu0;
  return v;
}

}  // namespace varbo::vhgp
