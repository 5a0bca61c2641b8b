#include "varbo/away_from_failures.hpp"

#include <stdexcept>

namespace varbo {

AwayFromFailures::AwayFromFailures(const RegionConstraint& inner, const Mat& successes, const Mat& failed)
    : inner_(inner), successes_(successes), failed_(failed) {
  if (successes.rows() == 0 || failed.rows() == 0 || successes.cols() != failed.cols())
    throw std::logic_error("AwayFromFailures: needs successful and failed points of one dimension");
}

double AwayFromFailures::constraint(const Vec& x, Vec* grad) const {
  Index s = 0, f = 0;
  (successes_.rowwise() - x.transpose()).rowwise().squaredNorm().minCoeff(&s);
  (failed_.rowwise() - x.transpose()).rowwise().squaredNorm().minCoeff(&f);
  constexpr double m2 = kFailureMargin * kFailureMargin;
  const double cell =
      (failed_.row(f).transpose() - x).squaredNorm() - m2 * (successes_.row(s).transpose() - x).squaredNorm();
  if (inner_.has_constraint()) {
    Vec g_inner(x.size());
    const double c_inner = inner_.constraint(x, grad ? &g_inner : nullptr);
    if (c_inner < cell) {
      if (grad) *grad = g_inner;
      return c_inner;
    }
  }
  if (grad) *grad = 2.0 * (x - failed_.row(f).transpose()) - 2.0 * m2 * (x - successes_.row(s).transpose());
  return cell;
}

}  // namespace varbo
