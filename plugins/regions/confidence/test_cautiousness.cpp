// The cautiousness report of CRBO (Fröhlich 2021, section 4.1).
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
  CHECK(rep.worst_case == doctest::Approx(rep.incumbent_mean + rep.r0 * rep.lipschitz));
  CHECK(rep.r0 == doctest::Approx(single_point_radius(ReportKernel::SquaredExponential, 0.3, 0.6)));
  const CautiousnessReport again = cautiousness_report(gp, data, 0.6, ReportKernel::SquaredExponential, r2);
  CHECK(again.lipschitz == rep.lipschitz);  // deterministic per seed

  ConfidenceRegion region(2, ConfidenceRegionOptions{});
  Rng ur(2);
  region.update(&gp, data, ur);
  CHECK(region.state().find("cautiousness: r0") != std::string::npos);
}
