#include <cmath>

#include "confidence_region.hpp"
#include "fake_gp.hpp"
#include "varbo/errors.hpp"
#include "varbo/function.hpp"
#include "varbo/log.hpp"
#include "study_helpers.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {
Dataset three_points() {
  Dataset d = Dataset::empty(2);
  d.add((Vec(2) << 0.3, 0.4).finished(), 1.0);
  d.add((Vec(2) << 0.5, 0.5).finished(), 0.2);
  d.add((Vec(2) << 0.7, 0.3).finished(), 0.7);
  return d;
}
}  // namespace

TEST_CASE("confidence region: constraint gradient matches finite differences") {
  test::FakeSEGP gp(1.3, 0.2, 1e-3);
  const Dataset data = three_points();
  gp.condition(data);
  ConfidenceRegion region(2, {});
  Rng rng(1);
  region.update(&gp, data, rng);
  FunctionRef c(2, [&](const Vec& x, Vec* g) { return region.constraint(x, g); });
  Rng pts(7);
  for (int t = 0; t < 20; ++t) {
    const Vec x = pts.uniform_vec(2);
    const GradientCheck chk = check_gradient(c, x, 1e-6);
    // Central differences, h = 1e-6: truncation O(h²) and roundoff ~1e-16/1e-6 ⇒ 1e-6 relative is ample.
    CHECK(chk.max_rel_error < 1e-6);
  }
}

TEST_CASE("confidence region: value is gamma^2 sigma_f^2 minus the latent variance, not the noise") {
  // With a large noise variance, a noise-including constraint would exclude everything.
  test::FakeSEGP gp(2.0, 0.2, 0.5);
  const Dataset data = three_points();
  gp.condition(data);
  ConfidenceRegionOptions o;
  o.gamma = 0.9;
  ConfidenceRegion region(2, o);
  Rng rng(1);
  region.update(&gp, data, rng);
  const Vec x = (Vec(2) << 0.45, 0.45).finished();
  const Prediction p = gp.predict(x, false);
  CHECK(region.constraint(x, nullptr) == doctest::Approx(0.81 * 2.0 - p.latent_var).epsilon(1e-12));
  CHECK(region.widenings() == 0);
  // Far from the data the latent variance is σ_f²: outside for any γ < 1.
  CHECK_FALSE(region.contains((Vec(2) << 0.0, 1.0).finished()));
}

TEST_CASE("confidence region: contains the data and its neighbourhood; seeds are the data") {
  test::FakeSEGP gp(1.0, 0.2, 1e-4);
  const Dataset data = three_points();
  gp.condition(data);
  ConfidenceRegion region(2, {});
  Rng rng(3);
  region.update(&gp, data, rng);
  CHECK(region.widenings() == 0);
  for (Index i = 0; i < data.size(); ++i) CHECK(region.contains(data.X.row(i).transpose()));
  const Mat s = region.seeds();
  CHECK(s.rows() == 3);
  CHECK((s - data.X).norm() == 0.0);
  // SE kernel, one point, σ_n² ≪ σ_f²: the region is about the ball of radius ℓ sqrt(−log(1 − γ²)) (section 4.1).
  test::FakeSEGP single(1.0, 0.2, 1e-8);
  Dataset one = Dataset::empty(2);
  one.add((Vec(2) << 0.5, 0.5).finished(), 0.0);
  single.condition(one);
  region.update(&single, one, rng);
  const double r0 = 0.2 * std::sqrt(-std::log(1 - 0.36));
  CHECK(region.contains((Vec(2) << 0.5 + 0.99 * r0, 0.5).finished()));
  CHECK_FALSE(region.contains((Vec(2) << 0.5, 0.5 + 1.01 * r0).finished()));
}

TEST_CASE("confidence region: widens when only the data satisfy it, and logs it") {
  // Noise so large that even the data are barely known: latent variance at a single point is
  // σ_f² σ_n²/(σ_f² + σ_n²) = 0.5 > γ² σ_f² = 0.36, so C_n is empty until widened.
  test::FakeSEGP gp(1.0, 0.2, 1.0);
  Dataset one = Dataset::empty(2);
  one.add((Vec(2) << 0.5, 0.5).finished(), 0.0);
  gp.condition(one);
  ConfidenceRegion region(2, {});
  Rng rng(5);
  region.update(&gp, one, rng);
  // 0.36 · 1.2^k > 0.5 first for k = 2 (0.5184), and the probes at 0.01 need a little more margin, not more
  // than one more step: 0.36 · 1.2^3 = 0.622.
  CHECK(region.widenings() >= 2);
  CHECK(region.widenings() <= 3);
  CHECK(region.contains(one.X.row(0).transpose()));
  CHECK(region.effective_gamma() == doctest::Approx(0.6 * std::sqrt(region.variance_scale())));
  // Widened until non-empty: no "still empty" warning (probing again with new probes said so on every trial; red
  // team, session 30).
  const std::string log = test::temp_folder("confidence_widen_log") + "/log.txt";
  set_log_file(log);
  for (int i = 0; i < 3; ++i) region.update(&gp, one, rng);
  set_log_file("");
  CHECK(test::slurp(log).find("widened") != std::string::npos);
  CHECK(test::slurp(log).find("still empty") == std::string::npos);
}

TEST_CASE("confidence region: before any update it is the whole box; invalid gamma is a ConfigError") {
  ConfidenceRegion region(3, {});
  CHECK(region.contains(Vec::Constant(3, 0.9)));
  CHECK(region.seeds().rows() == 0);
  ConfidenceRegionOptions bad;
  bad.gamma = 1.5;
  CHECK_THROWS_AS(ConfidenceRegion(3, bad), ConfigError);
}

TEST_CASE("confidence region: registered as a plugin with its capability tags") {
  const auto& info = test::registry().find(Kind::Region, "confidence");
  CHECK(info.provides == std::vector<std::string>{"region:constraint"});
  CHECK(info.needs == std::vector<std::string>{"optimizer:constraints"});
  BuildContext ctx;
  ctx.dim = 2;
  auto region = test::registry().create<RegionConstraint>("{type: confidence, gamma: 0.5}", ctx);
  CHECK(region->has_constraint());
  CHECK_THROWS_AS(test::registry().create<RegionConstraint>("{type: confidence, gamma: 1.5}", ctx), ConfigError);
}
