// `bo` when its acquisition optimizer reports failure (issue 12, item 10): the x of a failed result is arbitrary
// (sample_polish returns the box centre, possibly outside the confidence region) and must never be suggested.
#include <algorithm>
#include <limits>

#include "varbo/algorithm.hpp"
#include "varbo/log.hpp"
#include "varbo/optimizer.hpp"
#include "varbo/registry.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {

/// Finds nothing: success = false at the box centre, as sample_polish does when no candidate had a finite value.
class FailingOptimizer final : public Optimizer {
 public:
  OptimizeResult maximize(const DifferentiableFunction&, const RegionConstraint& region, const Mat&,
                          Rng&) const override {
    OptimizeResult r;
    r.x = 0.5 * (region.bounds().lower + region.bounds().upper);
    r.message = "test: no finite value at a feasible point";
    return r;
  }
};

void register_failing_optimizer() {
  if (test::registry().try_find(Kind::Optimizer, "test_failing") != nullptr) return;
  test::registry().add(make_component<Optimizer>(
      "test_failing", "always fails (test)", {},
      Factory<Optimizer>([](const Options&, const BuildContext&) -> std::unique_ptr<Optimizer> {
        return std::make_unique<FailingOptimizer>();
      }),
      {"optimizer:constraints"}));
}

}  // namespace

TEST_CASE("bo: a failed acquisition optimization suggests the best feasible start, not the optimizer's x") {
  set_log_level(LogLevel::Error);
  register_failing_optimizer();
  BuildContext ctx;
  ctx.dim = 2;
  ctx.budget = 10;
  ctx.seed = 3;
  // Short lengthscales: the confidence region is a few small discs around the data in a corner, far from the
  // box centre (0.5, 0.5).
  auto a = test::registry().create<Algorithm>(
      "{type: bo, initial_points: 4, surrogate: {type: gp, restarts: 1, max_lengthscale: 0.1}, "
      "region: {type: confidence, gamma: 0.6}, acquisition_optimizer: {type: test_failing}}",
      ctx);
  const Mat data = (Mat(4, 2) << 0.1, 0.1, 0.15, 0.1, 0.1, 0.2, 0.2, 0.15).finished();
  for (Index i = 0; i < data.rows(); ++i) {
    const Vec x = data.row(i).transpose();
    a->tell({Observation{x, (x.array() - 0.12).square().sum(), true, {}}});
  }
  const Suggestion s = a->ask(1).front();
  CAPTURE(s.x.transpose());
  double nearest = std::numeric_limits<double>::infinity();
  for (Index i = 0; i < data.rows(); ++i) nearest = std::min(nearest, (data.row(i).transpose() - s.x).norm());
  // The starts are the data points and copies moved by N(0, 0.01²) per coordinate.
  CHECK(nearest < 0.06);
  CHECK((s.x - Vec::Constant(2, 0.5)).norm() > 0.3);
}
