#include "ceres_lbfgs.hpp"

#include <ceres/gradient_problem.h>
#include <ceres/gradient_problem_solver.h>

#include <cmath>
#include <exception>

namespace varbo::ceres_lbfgs {

namespace {

/// −f for Ceres, which minimizes. A non-finite value or gradient, or an exception from f, is reported
/// as a failed evaluation (return false) so that Ceres shortens its step instead of the process dying.
class NegatedFunction final : public ceres::FirstOrderFunction {
 public:
  explicit NegatedFunction(const DifferentiableFunction& f) : f_(f) {}

  bool Evaluate(const double* parameters, double* cost, double* gradient) const override {
    ++evaluations_;
    const Vec x = Eigen::Map<const Vec>(parameters, f_.dim());
    try {
      Vec g;
      const double v = evaluate(x, gradient ? &g : nullptr);
      if (!std::isfinite(v)) return false;
      *cost = -v;
      if (gradient) {
        if (g.size() != f_.dim() || !g.allFinite()) return false;
        Eigen::Map<Vec>(gradient, f_.dim()) = -g;
      }
      return true;
    } catch (const std::exception&) {
      return false;
    }
  }
  int NumParameters() const override { return static_cast<int>(f_.dim()); }
  Index evaluations() const { return evaluations_; }

 private:
  double evaluate(const Vec& x, Vec* grad) const {
    if (grad == nullptr || f_.has_gradient()) return f_.value(x, grad);
    // No analytic gradient: central differences, step relative to max(1, |x_i|).
    const double v = f_.value(x, nullptr);
    grad->resize(x.size());
    Vec z = x;
    for (Index i = 0; i < x.size(); ++i) {
      const double h = 1e-6 * std::max(1.0, std::abs(x(i)));
      z(i) = x(i) + h;
      const double up = f_.value(z, nullptr);
      z(i) = x(i) - h;
      const double down = f_.value(z, nullptr);
      z(i) = x(i);
      (*grad)(i) = (up - down) / (2 * h);
    }
    return v;
  }

  const DifferentiableFunction& f_;
  mutable Index evaluations_ = 0;
};

}  // namespace

OptimizeResult CeresLbfgs::run_from(const DifferentiableFunction& f, const Vec& start) const {
  ceres::GradientProblemSolver::Options options;
  options.line_search_direction_type = ceres::LBFGS;
  options.max_num_iterations = settings_.max_iterations;
  options.function_tolerance = settings_.function_tolerance;
  options.gradient_tolerance = settings_.gradient_tolerance;
  options.parameter_tolerance = settings_.parameter_tolerance;
  options.max_lbfgs_rank = settings_.lbfgs_rank;
  options.logging_type = ceres::SILENT;
  options.minimizer_progress_to_stdout = false;

  auto* negated = new NegatedFunction(f);  // owned by the problem
  ceres::GradientProblem problem(negated);
  ceres::GradientProblemSolver::Summary summary;
  Vec x = start;
  ceres::Solve(options, problem, x.data(), &summary);

  OptimizeResult r;
  r.evaluations = negated->evaluations();
  r.iterations = static_cast<Index>(summary.iterations.size());
  r.message = summary.message;
  r.success = summary.IsSolutionUsable() && std::isfinite(summary.final_cost) && x.allFinite();
  if (r.success) {
    r.x = x;
    r.value = -summary.final_cost;
  } else {
    r.x = start;
  }
  return r;
}

OptimizeResult CeresLbfgs::maximize(const DifferentiableFunction& f, const RegionConstraint& region,
                                    const Mat& starts, Rng& rng) const {
  Mat use = starts;
  if (use.rows() == 0) {
    // No start given: a uniform point of the box (its centre when the box is unbounded).
    const Box& box = region.bounds();
    Vec x(f.dim());
    for (Index i = 0; i < f.dim(); ++i) {
      const bool finite = i < box.dim() && std::isfinite(box.lower(i)) && std::isfinite(box.upper(i));
      x(i) = finite ? rng.uniform(box.lower(i), box.upper(i)) : 0.0;
    }
    use = x.transpose();
  }
  OptimizeResult best;
  best.x = use.row(0).transpose();
  best.message = "no start succeeded";
  Index evaluations = 0, iterations = 0;
  for (Index k = 0; k < use.rows(); ++k) {
    OptimizeResult r = run_from(f, use.row(k).transpose());
    evaluations += r.evaluations;
    iterations += r.iterations;
    if (r.success && (!best.success || r.value > best.value)) best = std::move(r);  // ties: first start wins
  }
  best.evaluations = evaluations;
  best.iterations = iterations;
  return best;
}

}  // namespace varbo::ceres_lbfgs
