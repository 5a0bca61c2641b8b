#include "noise_models.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace varbo::tasks::noisy {

std::vector<std::string> noise_model_names() {
  return {"none", "additive", "multiplicative", "uniform_multiplicative", "cauchy", "input_dependent"};
}

NoiseModel noise_model_from_name(const std::string& name) {
  const auto names = noise_model_names();
  for (std::size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return static_cast<NoiseModel>(i);
  throw std::invalid_argument("unknown noise model '" + name + "'");
}

std::string noise_model_name(NoiseModel m) { return noise_model_names()[static_cast<std::size_t>(m)]; }

NoiseLevel noise_level_from_name(const std::string& name) {
  if (name == "moderate") return NoiseLevel::Moderate;
  if (name == "severe") return NoiseLevel::Severe;
  throw std::invalid_argument("unknown noise level '" + name + "' (moderate | severe)");
}

std::string noise_level_name(NoiseLevel l) { return l == NoiseLevel::Moderate ? "moderate" : "severe"; }

bool heteroscedastic(NoiseModel m) {
  return m == NoiseModel::Multiplicative || m == NoiseModel::UniformMultiplicative || m == NoiseModel::Cauchy ||
         m == NoiseModel::InputDependent;
}

Noise Noise::make(NoiseModel model, NoiseLevel level, Index d) {
  Noise n;
  n.model = model;
  n.level = level;
  const bool severe = level == NoiseLevel::Severe;
  const double dd = static_cast<double>(std::max<Index>(d, 1));
  switch (model) {
    case NoiseModel::None: break;
    case NoiseModel::Additive:
    case NoiseModel::InputDependent: n.sigma = severe ? 1.0 : 0.1; break;
    case NoiseModel::Multiplicative: n.beta = severe ? 1.0 : 0.01; break;
    case NoiseModel::UniformMultiplicative:
      n.alpha = (severe ? 1.0 : 0.01) * (0.49 + 1 / dd);
      n.beta = severe ? 1.0 : 0.01;
      break;
    case NoiseModel::Cauchy:
      n.alpha = severe ? 1.0 : 0.01;
      n.p = severe ? 0.2 : 0.05;
      break;
  }
  return n;
}

double Noise::input_sigma(const Vec& u) const { return sigma * (0.02 + 1.98 * u.mean()); }

double Noise::apply(double g, const Vec& u, Rng& rng) const {
  double out = g;
  switch (model) {
    case NoiseModel::None: return g;
    case NoiseModel::Additive: out = g + sigma * rng.normal(); break;
    case NoiseModel::Multiplicative: out = std::max(g, 0.0) * std::exp(beta * rng.normal()); break;
    case NoiseModel::UniformMultiplicative: {
      const double gp = std::max(g, 0.0);
      const double u1 = rng.uniform(), u2 = rng.uniform();
      out = gp * std::pow(u1, beta) * std::max(1.0, std::pow(1e9 / (gp + 1e-99), alpha * u2));
      break;
    }
    case NoiseModel::Cauchy: {
      // Always three draws, so the stream advances alike whether or not this evaluation is hit.
      const double u0 = rng.uniform(), n1 = rng.normal(), n2 = rng.normal();
      const double c = u0 < p ? n1 / (std::abs(n2) + 1e-199) : 0.0;
      out = g + alpha * std::max(-1000.0, c);
      break;
    }
    case NoiseModel::InputDependent: out = g + input_sigma(u) * rng.normal(); break;
  }
  // pow(0, 0) and 0·inf cannot occur above (g ≥ 0 finite, 1e9/(g + 1e-99) finite), but a cost must be finite.
  if (std::isnan(out)) return g;
  return std::clamp(out, -kNoiseClip, kNoiseClip);
}

std::string Noise::describe() const {
  const std::string lv = noise_level_name(level);
  switch (model) {
    case NoiseModel::None: return "none";
    case NoiseModel::Additive: return fmt::format("additive {}: g + {} N", lv, sigma);
    case NoiseModel::Multiplicative: return fmt::format("multiplicative {}: g exp({} N)", lv, beta);
    case NoiseModel::UniformMultiplicative:
      return fmt::format("uniform_multiplicative {}: g U1^{} max(1, (1e9/g)^({:.4g} U2))", lv, beta, alpha);
    case NoiseModel::Cauchy:
      return fmt::format("cauchy {}: g + {} max(-1000, 1{{U < {}}} N1/|N2|)", lv, alpha, p);
    case NoiseModel::InputDependent:
      return fmt::format("input_dependent {}: g + {} (0.02 + 1.98 mean(u)) N", lv, sigma);
  }
  return "";
}

}  // namespace varbo::tasks::noisy
