#include "component_outputs.hpp"

#include <fmt/format.h>

#include <cmath>
#include <stdexcept>

namespace varbo::bo {

Prediction check_surrogate_outputs(const Surrogate& model, const std::string& model_name, const Vec& x, Index dim) {
  Prediction p = model.predict(x, true);
  auto fail = [&](const std::string& what) {
    throw std::runtime_error(fmt::format("surrogate '{}' returned {} (a prediction at a point of dimension {}); the "
                                         "surrogate's predict() is wrong",
                                         model_name, what, dim));
  };
  // Only the sizes: a non-finite mean or variance is numerical trouble with the data (costs near the overflow of
  // their squares), which the acquisition optimizer's fallback survives; a wrong length is a bug, and undefined
  // behaviour in the code that reads it.
  const struct {
    const char* name;
    const Vec& v;
  } gradients[] = {{"d_mean", p.d_mean},
                   {"d_latent_var", p.d_latent_var},
                   {"d_log_noise_mean", p.d_log_noise_mean},
                   {"d_log_noise_var", p.d_log_noise_var}};
  // A model without gradients leaves all four empty (has_gradient() false); then the acquisition optimizers work
  // without them. Any other length is a bug, and so is a mix of filled and empty ones.
  const bool none = p.d_mean.size() == 0;
  for (const auto& g : gradients)
    if (g.v.size() != (none ? 0 : dim))
      fail(fmt::format("a gradient {} of length {}, expected {}{}", g.name, g.v.size(), dim,
                       none ? " (d_mean is empty: no gradients at all)" : ""));
  return p;
}

std::string unusable_prediction(const Prediction& p) {
  if (!std::isfinite(p.mean)) return fmt::format("a mean of {}", p.mean);
  if (!(p.latent_var >= 0) || !std::isfinite(p.latent_var)) return fmt::format("a latent variance of {}", p.latent_var);
  if (!std::isfinite(p.log_noise_mean) || !(p.log_noise_var >= 0) || !std::isfinite(p.log_noise_var))
    return fmt::format("a log noise variance of mean {} and variance {}", p.log_noise_mean, p.log_noise_var);
  return {};
}

void check_acquisition_outputs(const Acquisition& acquisition, const std::string& acquisition_name, const Vec& x,
                               Index dim) {
  if (!acquisition.has_gradient()) return;
  Vec grad = Vec::Zero(dim);
  acquisition.evaluate(x, &grad);
  if (grad.size() != dim)
    throw std::runtime_error(fmt::format("acquisition '{}' returned a gradient of length {} at a point of dimension "
                                         "{}; its evaluate() is wrong (or it should declare has_gradient() false)",
                                         acquisition_name, grad.size(), dim));
}

Mat check_sampler_outputs(Mat m, const std::string& sampler_name, Index n, Index dim, bool fewer_ok) {
  std::string bad;
  if (m.rows() > n || (!fewer_ok && m.rows() < n))
    bad = fmt::format("{} points when asked for {}", m.rows(), n);
  else if (m.rows() > 0 && m.cols() != dim)
    bad = fmt::format("points of dimension {}, expected {}", m.cols(), dim);
  else if (!m.allFinite())
    bad = "a point with a non-finite coordinate";
  else if (m.size() > 0 && (m.minCoeff() < -1e-9 || m.maxCoeff() > 1 + 1e-9))
    bad = "a point outside the unit cube";
  if (!bad.empty())
    throw std::runtime_error(
        fmt::format("sampler '{}' returned {}; its sample() is wrong", sampler_name, bad));
  return m;
}

void check_region_outputs(const RegionConstraint& region, const std::string& region_name, Index dim) {
  const Box& b = region.bounds();
  std::string bad;
  if (b.lower.size() != dim || b.upper.size() != dim)
    bad = fmt::format("bounds of dimension {} and {}, expected {}", b.lower.size(), b.upper.size(), dim);
  else if (!b.lower.allFinite() || !b.upper.allFinite())
    bad = "bounds with a non-finite coordinate";
  else if ((b.lower.array() > b.upper.array()).any())
    bad = "bounds whose lower corner exceeds the upper one";
  else if (dim > 0 && (b.lower.minCoeff() < -1e-9 || b.upper.maxCoeff() > 1 + 1e-9))
    bad = "bounds outside the unit cube";
  if (!bad.empty())
    throw std::runtime_error(fmt::format("region '{}' returned {}; its bounds() is wrong", region_name, bad));
  // The acquisition's starts are built from the seeds row by row: seeds of another width were read past their
  // end (a one-column seeds() in a 2-D problem: invalid reads under valgrind, exit 0; audit, session 48).
  const Mat seeds = region.seeds();
  if (seeds.rows() > 0 && seeds.cols() != dim)
    bad = fmt::format("seeds of dimension {}, expected {}", seeds.cols(), dim);
  else if (!seeds.allFinite())
    bad = "a seed with a non-finite coordinate";
  else if (seeds.size() > 0 && (seeds.minCoeff() < -1e-9 || seeds.maxCoeff() > 1 + 1e-9))
    bad = "a seed outside the unit cube";
  if (!bad.empty())
    throw std::runtime_error(fmt::format("region '{}' returned {}; its seeds() is wrong", region_name, bad));
}

}  // namespace varbo::bo
