#include "varbo/constrained_sampling.hpp"

#include "varbo/optimizer.hpp"
#include "varbo/space_wrappers.hpp"

namespace varbo {

Mat sample_unit_cube(const Sampler& sampler, const SharedSpace& space, Index d, Index n, Rng& rng) {
  if (!space || !space->has_constraints()) return sampler.sample(BoxRegion(Box::unit(d)), n, rng);
  const auto feasible = respect_constraints(std::make_unique<BoxRegion>(Box::unit(d)), space);
  Mat m = sampler.sample(*feasible, n, rng);
  if (m.rows() >= n) return m;
  Mat all(n, d);
  all << m, sampler.sample(BoxRegion(Box::unit(d)), n - m.rows(), rng);
  return all;
}

}  // namespace varbo
