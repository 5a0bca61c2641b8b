#include <cmath>

#include "around_initial_point.hpp"
#include "varbo/errors.hpp"
#include "varbo/optimizer.hpp"
#include "varbo_test.hpp"

using namespace varbo;
using sampling::AroundInitialPointOptions;
using sampling::AroundInitialPointSampler;

TEST_CASE("r0 makes a single noise-free SE observation's latent variance exactly gamma^2 sigma_f^2") {
  const double ell = 0.2, gamma = 0.6;
  const double r0 = sampling::single_point_radius_se(ell, gamma);
  // Closed form for the default: 0.2 * sqrt(-log(0.64)) = 0.133620...
  CHECK(r0 == doctest::Approx(0.2 * std::sqrt(-std::log(0.64))).epsilon(1e-14));
  // GP posterior variance after one noise-free point: σ² = σ_f² − k(r)²/σ_f², k(r) = σ_f² exp(−r²/(2ℓ²)).
  const double sf2 = 1.7;
  const double k = sf2 * std::exp(-r0 * r0 / (2 * ell * ell));
  CHECK(sf2 - k * k / sf2 == doctest::Approx(gamma * gamma * sf2).epsilon(1e-12));
  CHECK_THROWS_AS(sampling::single_point_radius_se(0.2, 1.0), ConfigError);
}

TEST_CASE("theta0 first, then points at distance r0 in orthogonal directions, deterministic per seed") {
  const Index d = 5;
  Vec c(d);
  c << 0.5, 0.4, 0.6, 0.5, 0.45;
  AroundInitialPointSampler s(AroundInitialPointOptions{}, c);
  BoxRegion box(Box::unit(d));
  Rng a(3), b(3), e(4);
  const Mat X = s.sample(box, 4, a);
  REQUIRE(X.rows() == 4);
  CHECK((X.row(0).transpose() - c).norm() == 0.0);
  for (Index k = 1; k < 4; ++k) CHECK((X.row(k).transpose() - c).norm() == doctest::Approx(s.radius()).epsilon(1e-12));
  // Orthogonal directions: (x1 − c)·(x2 − c) = 0.
  CHECK(std::abs((X.row(1).transpose() - c).dot(X.row(2).transpose() - c)) < 1e-12);
  CHECK((s.sample(box, 4, b) - X).norm() == 0.0);
  CHECK((s.sample(box, 4, e) - X).norm() > 0.0);
  // More points than 2d: negatives of the basis, then random directions; all at r0 here (far from the walls).
  Rng f(5);
  const Mat Y = s.sample(box, 2 * d + 3, f);
  for (Index k = 1; k < Y.rows(); ++k)
    CHECK((Y.row(k).transpose() - c).norm() == doctest::Approx(s.radius()).epsilon(1e-12));
  CHECK((Y.row(1) - c.transpose() + (Y.row(d + 1) - c.transpose())).norm() < 1e-12);  // u and −u
}

TEST_CASE("points are clipped into the box; no initial point means the box centre; explicit radius") {
  const Index d = 3;
  AroundInitialPointOptions o;
  o.radius = 0.4;
  AroundInitialPointSampler corner(o, Vec::Zero(d));
  BoxRegion box(Box::unit(d));
  Rng rng(1);
  const Mat X = corner.sample(box, 7, rng);
  for (Index k = 0; k < X.rows(); ++k) CHECK(box.bounds().contains(X.row(k).transpose()));
  // θ0 in a corner: no point but the first is θ0 again (an outward direction was clamped back onto it; session 30).
  for (Index k = 1; k < X.rows(); ++k) CHECK(X.row(k).norm() > 0.0);
  // The same in 1-D at a bound: the second point is r0 inside.
  AroundInitialPointSampler bound(AroundInitialPointOptions{}, Vec::Zero(1));
  BoxRegion line(Box::unit(1));
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    Rng r1(seed);
    const Mat L = bound.sample(line, 3, r1);
    CHECK(L(0, 0) == 0.0);
    CHECK(L(1, 0) == doctest::Approx(bound.radius()));
    CHECK(L(2, 0) == doctest::Approx(bound.radius()));  // both directions of 1-D lead out or in: r0 inside
  }
  CHECK(corner.radius() == 0.4);
  AroundInitialPointSampler centre(AroundInitialPointOptions{}, std::nullopt);
  Rng r2(1);
  const Mat Z = centre.sample(box, 2, r2);
  CHECK((Z.row(0).transpose() - Vec::Constant(d, 0.5)).norm() == 0.0);
  CHECK(centre.sample(box, 0, r2).rows() == 0);
  AroundInitialPointSampler wrong(AroundInitialPointOptions{}, Vec::Zero(d + 1));
  CHECK_THROWS_AS(wrong.sample(box, 2, r2), InputError);
}

TEST_CASE("the plugin builds the sampler from the build context's initial point") {
  BuildContext ctx;
  ctx.registry = &test::registry();
  ctx.dim = 2;
  ctx.initial_point = Vec::Constant(2, 0.25);
  auto s = test::registry().create<Sampler>("{type: around_initial_point, radius: 0.1}", ctx);
  Rng rng(0);
  const Mat X = s->sample(BoxRegion(Box::unit(2)), 2, rng);
  CHECK((X.row(0).transpose() - Vec::Constant(2, 0.25)).norm() == 0.0);
  CHECK((X.row(1).transpose() - Vec::Constant(2, 0.25)).norm() == doctest::Approx(0.1));
}
