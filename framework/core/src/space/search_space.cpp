// SearchSpace: typed parameters, their unit-cube encoding (Garrido-Merchán & Hernández-Lobato 2020) and the
// admissible point of an encoded one. Constraints and their repair: search_space_constraints.cpp.
#include "varbo/search_space.hpp"

#include <fmt/format.h>

#include <cmath>
#include <limits>
#include <map>
#include <set>

#include "varbo/config.hpp"
#include "varbo/csv.hpp"
#include "varbo/errors.hpp"
#include "varbo/numbers.hpp"
#include "varbo/text.hpp"

namespace varbo {

SpaceAware::~SpaceAware() = default;

std::optional<ParameterProblem> check_parameter(const Parameter& p) {
  if (p.name.empty()) return ParameterProblem{"name", "expected a non-empty parameter name"};
  switch (p.type) {
    case ParameterType::Real:
    case ParameterType::Int:
      if (!std::isfinite(p.low) || !std::isfinite(p.high))
        return ParameterProblem{"low", "expected finite bounds low < high"};
      if (!(p.low < p.high))
        return ParameterProblem{"high", fmt::format("high ({}) must exceed low ({}){}", p.high, p.low,
                                                    p.low == p.high ? fmt::format("; a parameter held at one value is "
                                                                                  "{{name: {}, type: fixed, value: {}}}",
                                                                                  p.name, p.low)
                                                                    : std::string())};
      // [-1e308, 1e308]: each bound finite, the width not; the task's domain check then blamed `task:` (audit,
      // session 47). Said here, at the parameter.
      if (!std::isfinite(p.high - p.low))
        return ParameterProblem{"high", fmt::format("the width high - low of [{}, {}] is not finite (at most about "
                                                    "1.8e308); rescale the parameter", p.low, p.high)};
      if (p.type == ParameterType::Int && (p.low != std::round(p.low) || p.high != std::round(p.high)))
        return ParameterProblem{p.low != std::round(p.low) ? "low" : "high",
                                fmt::format("an int parameter needs integer bounds, got [{}, {}]", p.low, p.high)};
      if (p.log && !(p.low > 0))
        return ParameterProblem{"low", fmt::format("a log-scaled parameter needs low > 0, got {}", p.low)};
      break;
    case ParameterType::Categorical: {
      if (p.choices.empty()) return ParameterProblem{"choices", "expected a non-empty list of labels"};
      // As an int with low == high (audit, session 49: a one-choice categorical ran, a coordinate of the model
      // that can never vary).
      if (p.choices.size() == 1)
        return ParameterProblem{"choices", fmt::format("expected at least two labels; a parameter held at one value "
                                                       "is {{name: {}, type: fixed, value: {}}}",
                                                       p.name, p.choices.front())};
      std::set<std::string> seen;
      std::map<std::string, std::size_t> written;  // printable form -> the index of the choice written so
      for (std::size_t j = 0; j < p.choices.size(); ++j) {
        const std::string& c = p.choices[j];
        if (c.empty()) return ParameterProblem{"choices", "expected non-empty labels"};
        if (!seen.insert(c).second) return ParameterProblem{"choices", fmt::format("duplicate choice '{}'", c)};
        // trials.csv, export and the summary write a label's control characters escaped (a newline as the two
        // characters "\n"), and the reader accepts that form: a label with a real newline and one with a
        // backslash and an n were one category to `varbo select` (audit, session 45).
        const auto [at, fresh] = written.emplace(printable(c), j);
        if (!fresh)
          return ParameterProblem{"choices", fmt::format("choices {} and {} are both written '{}' in trials.csv (a "
                                                         "control character is written escaped there, a newline as "
                                                         "\\n): rename one",
                                                         at->second + 1, j + 1, at->first)};
      }
      break;
    }
    case ParameterType::Fixed:
      if (p.choices.empty() && !std::isfinite(p.value)) return ParameterProblem{"value", "expected a finite number or a label"};
      break;
  }
  return std::nullopt;
}

SearchSpace::SearchSpace(std::vector<Parameter> params) : params_(std::move(params)) {
  if (params_.empty()) throw ConfigError("expected at least one parameter");
  std::set<std::string> seen;
  for (const auto& p : params_) {
    if (auto problem = check_parameter(p))
      throw ConfigError(fmt::format("parameter '{}': {}: {}", p.name, problem->key, problem->message));
    if (!seen.insert(p.name).second) throw ConfigError(fmt::format("duplicate parameter name '{}'", p.name));
  }
  layout();
  finalize();
}

SearchSpace SearchSpace::from_box(const Box& box, const std::vector<std::string>& names) {
  std::vector<Parameter> ps;
  for (Index i = 0; i < box.dim(); ++i) {
    Parameter p;
    p.name = static_cast<std::size_t>(i) < names.size() ? names[static_cast<std::size_t>(i)] : fmt::format("x{}", i + 1);
    p.low = box.lower[i];
    p.high = box.upper[i];
    ps.push_back(p);
  }
  return SearchSpace(std::move(ps));
}

void SearchSpace::layout() {
  offset_.clear();
  discrete_.clear();
  encoded_dim_ = 0;
  for (const auto& p : params_) {
    offset_.push_back(encoded_dim_);
    Index w = 0;
    if (p.type == ParameterType::Real || p.type == ParameterType::Int) w = 1;
    else if (p.type == ParameterType::Categorical) w = static_cast<Index>(p.choices.size());
    encoded_dim_ += w;
    for (Index k = 0; k < w; ++k) discrete_.push_back(p.type == ParameterType::Real ? 0 : 1);
  }
}

std::vector<std::string> SearchSpace::names() const {
  std::vector<std::string> out;
  for (const auto& p : params_) out.push_back(p.name);
  return out;
}

std::optional<std::size_t> SearchSpace::index_of(const std::string& name) const {
  for (std::size_t i = 0; i < params_.size(); ++i)
    if (params_[i].name == name) return i;
  return std::nullopt;
}

bool SearchSpace::has_discrete() const {
  for (const auto& p : params_)
    if (p.type == ParameterType::Int || p.type == ParameterType::Categorical) return true;
  return false;
}

bool SearchSpace::has_log() const {
  for (const auto& p : params_)
    if (p.log) return true;
  return false;
}

Box SearchSpace::user_box() const {
  const Index n = static_cast<Index>(params_.size());
  Box b{Vec(n), Vec(n)};
  for (Index i = 0; i < n; ++i) {
    const Parameter& p = params_[static_cast<std::size_t>(i)];
    switch (p.type) {
      case ParameterType::Real:
      case ParameterType::Int: b.lower[i] = p.low; b.upper[i] = p.high; break;
      case ParameterType::Categorical: b.lower[i] = 0; b.upper[i] = static_cast<double>(p.choices.size() - 1); break;
      case ParameterType::Fixed: b.lower[i] = b.upper[i] = p.value; break;
    }
  }
  return b;
}

namespace {
// The interval an encoded coordinate spans, in value units or log units: an integer owns [n − ½, n + ½].
std::pair<double, double> coordinate_span(const Parameter& p) {
  double a = p.low, b = p.high;
  if (p.type == ParameterType::Int) {
    a -= 0.5;
    b += 0.5;
  }
  if (p.log) return {std::log(a), std::log(b)};
  return {a, b};
}
}  // namespace

double SearchSpace::from_coordinate(std::size_t i, double u) const {
  const Parameter& p = params_[i];
  const auto [a, b] = coordinate_span(p);
  const double t = a + std::clamp(u, 0.0, 1.0) * (b - a);
  const double v = p.log ? std::exp(t) : t;
  return p.type == ParameterType::Real ? std::clamp(v, p.low, p.high) : v;
}

double SearchSpace::to_coordinate(std::size_t i, double v) const {
  const Parameter& p = params_[i];
  const auto [a, b] = coordinate_span(p);
  const double t = p.log ? std::log(v) : v;
  return std::clamp((t - a) / (b - a), 0.0, 1.0);
}

Vec SearchSpace::decode(const Vec& x) const {
  Vec theta(static_cast<Index>(params_.size()));
  for (std::size_t i = 0; i < params_.size(); ++i) {
    const Parameter& p = params_[i];
    const Index o = offset_[i];
    const auto k = static_cast<Index>(i);
    switch (p.type) {
      case ParameterType::Real: theta[k] = from_coordinate(i, x[o]); break;
      case ParameterType::Int: theta[k] = std::clamp(std::round(from_coordinate(i, x[o])), p.low, p.high); break;
      case ParameterType::Categorical: {
        Index best = 0;  // argmax; ties to the first label
        for (Index j = 1; j < static_cast<Index>(p.choices.size()); ++j)
          if (x[o + j] > x[o + best]) best = j;
        theta[k] = static_cast<double>(best);
        break;
      }
      case ParameterType::Fixed: theta[k] = p.value; break;
    }
  }
  return theta;
}

Vec SearchSpace::encode(const Vec& theta) const {
  Vec x = Vec::Zero(encoded_dim_);
  for (std::size_t i = 0; i < params_.size(); ++i) {
    const Parameter& p = params_[i];
    const Index o = offset_[i];
    const double v = theta[static_cast<Index>(i)];
    switch (p.type) {
      case ParameterType::Real: x[o] = to_coordinate(i, std::clamp(v, p.low, p.high)); break;
      case ParameterType::Int: x[o] = to_coordinate(i, std::clamp(std::round(v), p.low, p.high)); break;
      case ParameterType::Categorical: {
        const auto j = static_cast<Index>(std::clamp(std::round(v), 0.0, static_cast<double>(p.choices.size() - 1)));
        x[o + j] = 1.0;
        break;
      }
      case ParameterType::Fixed: break;
    }
  }
  return x;
}

Vec SearchSpace::round_discrete(const Vec& x) const {
  Vec y = x;
  for (std::size_t i = 0; i < params_.size(); ++i) {
    const Parameter& p = params_[i];
    const Index o = offset_[i];
    if (p.type == ParameterType::Int) {
      y[o] = to_coordinate(i, std::clamp(std::round(from_coordinate(i, x[o])), p.low, p.high));
    } else if (p.type == ParameterType::Categorical) {
      const auto k = static_cast<Index>(p.choices.size());
      Index best = 0;
      for (Index j = 1; j < k; ++j)
        if (x[o + j] > x[o + best]) best = j;
      y.segment(o, k).setZero();
      y[o + best] = 1.0;
    }
  }
  return y;
}

Box SearchSpace::widen_for_discrete(const Box& box) const {
  Box out = box;
  for (std::size_t i = 0; i < params_.size(); ++i) {
    const Parameter& p = params_[i];
    const Index o = offset_[i];
    if (p.type == ParameterType::Int) {
      const double v = std::clamp(std::round(from_coordinate(i, 0.5 * (box.lower[o] + box.upper[o]))), p.low, p.high);
      out.lower[o] = std::min(box.lower[o], to_coordinate(i, std::max(v - 1, p.low)));
      out.upper[o] = std::max(box.upper[o], to_coordinate(i, std::min(v + 1, p.high)));
    } else if (p.type == ParameterType::Categorical) {
      const auto k = static_cast<Index>(p.choices.size());
      out.lower.segment(o, k).setZero();
      out.upper.segment(o, k).setOnes();
    }
  }
  return out;
}

Vec SearchSpace::admissible(const Vec& x) const {
  const Vec y = round_discrete(Box::unit(encoded_dim_).clamp(x));
  if (constraints_.empty() || satisfies_constraints(y)) return y;
  return repair(y);
}

bool SearchSpace::contains(const Vec& theta, std::string* why, double tol) const {
  auto no = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (theta.size() != static_cast<Index>(params_.size()))
    return no(fmt::format("expected {} values ({}), got {}", params_.size(), join(names()), theta.size()));
  for (std::size_t i = 0; i < params_.size(); ++i) {
    const Parameter& p = params_[i];
    const double v = theta[static_cast<Index>(i)];
    if (!std::isfinite(v)) return no(fmt::format("{} = {} is not a finite number", p.name, v));
    switch (p.type) {
      case ParameterType::Real:
      case ParameterType::Int:
        if (v < p.low || v > p.high) return no(fmt::format("{} = {} is not in [{}, {}]", p.name, v, p.low, p.high));
        if (p.type == ParameterType::Int && v != std::round(v)) return no(fmt::format("{} = {} is not an integer", p.name, v));
        break;
      case ParameterType::Categorical:
        if (v != std::round(v) || v < 0 || v >= static_cast<double>(p.choices.size()))
          return no(fmt::format("{} = {} is not the index of one of {}", p.name, v, join(p.choices)));
        break;
      case ParameterType::Fixed:
        if (v != p.value) return no(fmt::format("{} is fixed at {}, got {}", p.name, format_value(i, p.value), v));
        break;
    }
  }
  for (const auto& c : constraints_) {
    // The tolerance is relative to the constraint's own magnitude at θ (its bound and each term there), not at
    // least 1: with parameters in farads (c1 + c2 <= 1e-10) an absolute 1e-9 accepted every violation (red team,
    // session 22); plus a few ulps of each term at the far end of its parameter's range, the rounding of a θ
    // decoded from the unit cube. The range itself times 1e-9 accepted f1 = f2 = 5e8 Hz for `f1 - f2 >= 1` over
    // [0, 1e9] and feasible sets that were empty (red team, session 26).
    constexpr double kRounding = 64 * std::numeric_limits<double>::epsilon();
    double lhs = 0, scale = std::abs(c.bound), rounding = 0;
    for (const auto& [i, a] : c.terms) {
      lhs += a * theta[static_cast<Index>(i)];
      const Parameter& q = params_[i];
      const double reach = q.type == ParameterType::Fixed ? std::abs(q.value)
                                                           : std::max(std::abs(q.low), std::abs(q.high));
      scale = std::max(scale, std::abs(a * theta[static_cast<Index>(i)]));
      rounding += kRounding * std::abs(a) * reach;
    }
    if (lhs > c.bound + std::max(tol * scale, rounding))
      // By how much, not "lhs > bound": a `>=` constraint is kept as −lhs <= −bound, and its sides printed
      // negated read as nonsense ("gain - 0.5*t1 >= -1 is violated (1.4 > 1)").
      return no(fmt::format("constraint '{}' is violated by {:.6g}", c.text, lhs - c.bound));
  }
  return true;
}

Params SearchSpace::params(const Vec& theta) const {
  Params out;
  for (std::size_t i = 0; i < params_.size(); ++i) {
    const Parameter& p = params_[i];
    ParamValue v;
    v.type = p.type;
    const double t = static_cast<Index>(i) < theta.size() ? theta[static_cast<Index>(i)] : p.value;
    if (p.type == ParameterType::Categorical) {
      const auto j = static_cast<std::size_t>(std::clamp(std::round(t), 0.0, static_cast<double>(p.choices.size() - 1)));
      v.label = p.choices[j];
      v.number = static_cast<double>(j);
    } else if (p.type == ParameterType::Fixed && !p.choices.empty()) {
      v.label = p.choices[0];
    } else {
      v.number = t;
    }
    out.names.push_back(p.name);
    out.values.push_back(std::move(v));
  }
  return out;
}

Vec SearchSpace::theta(const Params& in) const {
  Vec t(static_cast<Index>(params_.size()));
  for (std::size_t i = 0; i < params_.size(); ++i) {
    const Parameter& p = params_[i];
    if (!in.has(p.name)) throw InputError(fmt::format("parameter '{}' is missing (the space has {})", p.name, join(names())));
    const ParamValue& v = in.at(p.name);
    if (p.type == ParameterType::Categorical) {
      if (!v.is_label()) throw InputError(fmt::format("parameter '{}' expects one of {}", p.name, join(p.choices)));
      t[static_cast<Index>(i)] = parse_value(i, v.label);
    } else if (p.type == ParameterType::Fixed && !p.choices.empty()) {
      t[static_cast<Index>(i)] = 0;
    } else {
      if (v.is_label()) throw InputError(fmt::format("parameter '{}' expects a number, got '{}'", p.name, v.label));
      t[static_cast<Index>(i)] = v.number;
    }
  }
  return t;
}

double SearchSpace::parse_value(std::size_t i, const std::string& text) const {
  const Parameter& p = params_.at(i);
  if (p.type == ParameterType::Categorical) {
    for (std::size_t j = 0; j < p.choices.size(); ++j)
      if (p.choices[j] == text) return static_cast<double>(j);
    // trials.csv writes a label's control characters escaped (csv_text: a newline as the two characters "\n"): a
    // run whose label held one could not be read back (`varbo plot`/`select`: "is not one of its choices").
    for (std::size_t j = 0; j < p.choices.size(); ++j)
      if (printable(p.choices[j]) == text) return static_cast<double>(j);
    const std::string near = closest_match(text, p.choices);
    // "solver=1": an index where the label belongs (trials.csv, --param and tell_point all speak in labels).
    const bool index = parse_decimal(text).has_value();
    throw InputError(fmt::format("parameter '{}': '{}' is not one of its choices ({}){}{}", p.name, text,
                                 join(p.choices), near.empty() ? "" : "; did you mean '" + near + "'?",
                                 index ? "; a category is given by its label, not by its index" : ""));
  }
  if (p.type == ParameterType::Fixed && !p.choices.empty()) {
    if (text != p.choices[0])
      throw InputError(fmt::format("parameter '{}' is fixed at '{}', got '{}'", p.name, p.choices[0], text));
    return 0;
  }
  const std::optional<double> v = parse_decimal(text);
  if (!v || !std::isfinite(*v))
    throw InputError(fmt::format("parameter '{}': expected {}, got '{}'", p.name,
                                 p.type == ParameterType::Int ? "an integer" : "a finite decimal number", text));
  if (p.type == ParameterType::Int && *v != std::round(*v))
    throw InputError(fmt::format("parameter '{}' is an int parameter, got {}", p.name, text));
  if (p.type == ParameterType::Fixed) {
    if (*v != p.value) throw InputError(fmt::format("parameter '{}' is fixed at {}, got {}", p.name, exact(p.value), text));
  } else if (*v < p.low || *v > p.high) {
    throw InputError(fmt::format("parameter '{}' = {} is not in [{}, {}]", p.name, text, p.low, p.high));
  }
  return *v;
}

std::string SearchSpace::format_value(std::size_t i, double v) const {
  const Parameter& p = params_.at(i);
  if (p.type == ParameterType::Categorical) {
    const auto j = static_cast<std::size_t>(std::clamp(std::round(v), 0.0, static_cast<double>(p.choices.size() - 1)));
    return p.choices[j];
  }
  if (p.type == ParameterType::Fixed && !p.choices.empty()) return p.choices[0];
  if (p.type == ParameterType::Int && v == std::round(v) && std::abs(v) < 1e15) return fmt::format("{}", static_cast<long>(v));
  return exact(v);
}

}  // namespace varbo
