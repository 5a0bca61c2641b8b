// The cautiousness report of CRBO (Fröhlich 2021, section 4.1).
#include <algorithm>
#include <cmath>

#include "cautiousness.hpp"
#include "confidence_region.hpp"
#include "fake_gp.hpp"
#include "varbo_test.hpp"

using namespace varbo;

TEST_CASE("single-point radius: SE closed form, Matern-5/2 root, both equal the GP's gamma-level set") {
  const double ell = 0.2, gamma = 0.6;
  const double r_se = single_point_radius(ReportKernel::SquaredExponential, ell, gamma);
  CHECK(r_se == doctest::Approx(0.2 * std::sqrt(-std::log(0.64))).epsilon(1e-14));
  // The paper's eq. (4) is √2 larger.
  CHECK(paper_radius(ell, gamma) / r_se == doctest::Approx(std::sqrt(2.0)).epsilon(1e-14));
  // Exact GP with one noise-free point (SE): latent variance at distance r_se is γ²σ_f².
  test::FakeSEGP gp(2.0, ell, 1e-12);
  Dataset one = Dataset::empty(2);
  Vec x0 = Vec::Constant(2, 0.5);
  one.add(x0, 0.0);
  gp.condition(one);
  Vec x = x0;
  x(0) += r_se;
  CHECK(gp.predict(x, false).latent_var == doctest::Approx(gamma * gamma * 2.0).epsilon(1e-8));
  // Matérn-5/2: 1 − ρ(r)² = γ² at the root.
  const double r_m = single_point_radius(ReportKernel::Matern52, ell, gamma);
  const double a = std::sqrt(5.0) * r_m / ell;
  const double rho = (1 + a + a * a / 3) * std::exp(-a);
  CHECK(1 - rho * rho == doctest::Approx(gamma * gamma).epsilon(1e-12));
  CHECK(std::isinf(single_point_radius(ReportKernel::Matern52, ell, 1.0)));
}

TEST_CASE("Lipschitz estimate and worst case on a linear-ish model; the region's state carries the report") {
  // Data of a linear cost y = 3·x1 on a few points: the GP mean's gradient near the data is about 3.
  test::FakeSEGP gp(1.0, 0.3, 1e-6);
  Dataset data = Dataset::empty(2);
  Rng rng(1);
  for (int i = 0; i < 12; ++i) {
    const Vec x = rng.uniform_vec(2);
    data.add(x, 3 * x(0));
  }
  gp.condition(data);
  Rng r1(4), r2(4);
  const CautiousnessReport rep = cautiousness_report(gp, data, 0.6, ReportKernel::SquaredExponential, r1);
  CHECK(rep.lipschitz > 2.0);
  CHECK(rep.lipschitz < 10.0);
  CHECK(rep.worst_case == doctest::Approx(rep.incumbent_mean + rep.reach * rep.lipschitz));
  CHECK(rep.single_point_r0 == doctest::Approx(single_point_radius(ReportKernel::SquaredExponential, 0.3, 0.6)));
  const CautiousnessReport again = cautiousness_report(gp, data, 0.6, ReportKernel::SquaredExponential, r2);
  CHECK(again.lipschitz == rep.lipschitz);  // deterministic per seed

  ConfidenceRegion region(2, ConfidenceRegionOptions{});
  Rng ur(2);
  region.update(&gp, data, ur);
  CHECK(region.state().find("cautiousness: single-point r0") != std::string::npos);
  CHECK(region.state().find("region reach") != std::string::npos);
}

TEST_CASE("the region reaches farther than the single-point r0 from every data point; the report measures it") {
  // Issue 12, item 10: two close noise-free points reduce the variance together, so the region extends beyond r0
  // from both. 1-D, so a fine grid gives the true reach: max over region points of the distance to the nearest
  // data point.
  const double ell = 0.1, gamma = 0.6, sf2 = 1.0;
  test::FakeSEGP gp(sf2, ell, 1e-10);
  Dataset data = Dataset::empty(1);
  data.add(Vec::Constant(1, 0.40), 0.0);
  data.add(Vec::Constant(1, 0.47), 0.1);
  gp.condition(data);
  double actual = 0;
  for (int i = 0; i <= 100000; ++i) {
    const double x = i / 100000.0;
    if (gp.predict(Vec::Constant(1, x), false).latent_var <= gamma * gamma * sf2)
      actual = std::max(actual, std::min(std::abs(x - 0.40), std::abs(x - 0.47)));
  }
  Rng rng(7);
  const CautiousnessReport rep = cautiousness_report(gp, data, gamma, ReportKernel::SquaredExponential, rng);
  const double r0 = single_point_radius(ReportKernel::SquaredExponential, ell, gamma);
  CHECK(rep.single_point_r0 == doctest::Approx(r0));
  CHECK(actual > 1.2 * r0);  // the single-point radius is no bound here
  // Bisection to 1/64 of a step of r0/2; the grid to 1e-5.
  CHECK(rep.reach <= actual + 1e-5);
  CHECK(rep.reach >= actual - r0 / 128 - 1e-5);
  CHECK(rep.worst_case == doctest::Approx(rep.incumbent_mean + rep.reach * rep.lipschitz));
}
