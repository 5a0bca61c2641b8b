#include "varbo/constrained_sampling.hpp"

#include <fmt/format.h>

#include <exception>

#include "varbo/errors.hpp"
#include "varbo/optimizer.hpp"
#include "varbo/space_wrappers.hpp"

namespace varbo {

Mat sample_named(const Sampler& sampler, const std::string& sampler_name, const RegionConstraint& region, Index n,
                 Rng& rng) {
  if (sampler_name.empty()) return sampler.sample(region, n, rng);  // the caller names it itself
  try {
    return sampler.sample(region, n, rng);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw PluginCodeError(fmt::format("sampler '{}' threw: {}", sampler_name, e.what()));
  }
}

Mat sample_unit_cube(const Sampler& sampler, const std::string& sampler_name, const SharedSpace& space, Index d,
                     Index n, Rng& rng) {
  if (!space || !space->has_constraints()) return sample_named(sampler, sampler_name, BoxRegion(Box::unit(d)), n, rng);
  const auto feasible = respect_constraints(std::make_unique<BoxRegion>(Box::unit(d)), space);
  Mat m = sample_named(sampler, sampler_name, *feasible, n, rng);
  if (m.rows() >= n) return m;
  Mat all(n, d);
  all << m, sample_named(sampler, sampler_name, BoxRegion(Box::unit(d)), n - m.rows(), rng);
  return all;
}

Mat sample_unit_cube(const Sampler& sampler, const SharedSpace& space, Index d, Index n, Rng& rng) {
  return sample_unit_cube(sampler, std::string(), space, d, n, rng);
}

}  // namespace varbo
