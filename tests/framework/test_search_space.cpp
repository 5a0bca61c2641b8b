// SearchSpace (varbo/search_space.hpp): encoding round trips, the rounding transformation, constraint parsing
// and feasibility, the typed Params view, and the surrogate wrapper's constancy between admissible values.
#include <cmath>
#include <set>

#include "varbo/errors.hpp"
#include "varbo/named_values.hpp"
#include "varbo/search_space.hpp"
#include "varbo/search_space_config.hpp"
#include "varbo/space_wrappers.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {

SearchSpace issue_space() {
  // The example of issue 15.
  return parse_search_space(ConfigNode::parse(R"(
- {name: lr, type: real, low: 1.0e-5, high: 0.1, log: true}
- {name: waypoints, type: int, low: 2, high: 9}
- {name: step, type: int, low: 8, high: 256, log: true}
- {name: solver, type: categorical, choices: [pd, lqr, mpc]}
- {name: gain, type: real, low: -1, high: 1}
- {name: horizon, type: fixed, value: 3.0}
)", "p.yaml"));
}

std::string error_of(const std::string& yaml) {
  try {
    parse_search_space(ConfigNode::parse(yaml, "p.yaml"));
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

std::string constraint_error(const std::string& text) {
  const SearchSpace s = issue_space();
  try {
    parse_linear_constraint(text, s.parameters());
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("the layout: one coordinate per real or int, one per category, none for a fixed value") {
  const SearchSpace s = issue_space();
  CHECK(s.size() == 6);
  CHECK(s.encoded_dim() == 1 + 1 + 1 + 3 + 1);
  CHECK(s.has_discrete());
  CHECK(s.has_log());
  const Box b = s.user_box();
  CHECK(b.lower[3] == 0);
  CHECK(b.upper[3] == 2);
  CHECK(b.lower[5] == 3.0);
  CHECK(b.upper[5] == 3.0);
}

TEST_CASE("encode then decode returns every admissible θ exactly") {
  const SearchSpace s = issue_space();
  Rng rng(3);
  for (int k = 0; k < 500; ++k) {
    Vec theta(6);
    theta << std::exp(std::log(1e-5) + rng.uniform() * (std::log(0.1) - std::log(1e-5))), 2 + rng.index(8),
        8 + rng.index(249), static_cast<double>(rng.index(3)), rng.uniform(-1, 1), 3.0;
    const Vec back = s.decode(s.encode(theta));
    CHECK(back[1] == theta[1]);
    CHECK(back[2] == theta[2]);
    CHECK(back[3] == theta[3]);
    CHECK(back[5] == 3.0);
    CHECK(back[0] == doctest::Approx(theta[0]).epsilon(1e-12));
    CHECK(back[4] == doctest::Approx(theta[4]).epsilon(1e-12));
    CHECK(s.contains(back));
  }
}

TEST_CASE("log parameters are encoded in log space; integers own equal cells") {
  const SearchSpace s = issue_space();
  Vec theta(6);
  theta << 1e-3, 2, 8, 0, 0, 3;
  // (ln 1e-3 − ln 1e-5) / (ln 0.1 − ln 1e-5) = 2/4.
  CHECK(s.encode(theta)[0] == doctest::Approx(0.5).epsilon(1e-12));
  // waypoints ∈ {2..9}: 8 cells of width 1/8; the value 2 sits at the centre of the first, 1/16.
  CHECK(s.encode(theta)[1] == doctest::Approx(1.0 / 16).epsilon(1e-12));
  Vec x = s.encode(theta);
  for (int n = 0; n < 8; ++n) {
    x[1] = (n + 0.01) / 8;
    CHECK(s.decode(x)[1] == 2 + n);
    x[1] = (n + 0.99) / 8;
    CHECK(s.decode(x)[1] == 2 + n);
  }
}

TEST_CASE("categories: one-hot encoding, argmax decoding, and the rounding transformation") {
  const SearchSpace s = issue_space();
  Vec x = Vec::Constant(s.encoded_dim(), 0.3);
  x.segment(3, 3) << 0.2, 0.7, 0.4;
  CHECK(s.decode(x)[3] == 1);
  const Vec t = s.round_discrete(x);
  CHECK(t.segment(3, 3) == (Vec(3) << 0, 1, 0).finished());
  CHECK(t[0] == x[0]);  // continuous coordinates untouched
  CHECK(t[6] == x[6]);
  CHECK(s.admissible(s.admissible(x)) == s.admissible(x));
}

TEST_CASE("the typed Params view and values from text") {
  const SearchSpace s = issue_space();
  Vec theta(6);
  theta << 1e-3, 4, 16, 1, -0.5, 3;
  const Params p = s.params(theta);
  CHECK(p.real("lr") == 1e-3);
  CHECK(p.integer("waypoints") == 4);
  CHECK(p.label("solver") == "lqr");
  CHECK(p.real("horizon") == 3.0);
  CHECK_THROWS_AS(p.label("gain"), std::invalid_argument);
  CHECK_THROWS_AS(p.real("solver"), std::invalid_argument);
  CHECK(p.to_json() == R"({"lr": 0.001, "waypoints": 4, "step": 16, "solver": "lqr", "gain": -0.5, "horizon": 3})");
  CHECK(s.theta(p) == theta);
  CHECK(s.parse_value(3, "mpc") == 2);
  CHECK(s.parse_value(1, "7") == 7);
  CHECK_THROWS_AS(s.parse_value(1, "7.5"), InputError);
  CHECK_THROWS_AS(s.parse_value(1, "12"), InputError);
  CHECK_THROWS_AS(s.parse_value(3, "lqe"), InputError);
  // An index where the label belongs: said so, and no suggestion of an unrelated label.
  CHECK_THROWS_WITH_AS(s.parse_value(3, "1"), doctest::Contains("given by its label, not by its index"), InputError);
  try {
    s.parse_value(3, "1");
  } catch (const InputError& e) {
    CHECK(std::string(e.what()).find("did you mean") == std::string::npos);
  }
  CHECK_THROWS_AS(s.parse_value(5, "4"), InputError);
  CHECK(s.format_value(3, 2) == "mpc");
  CHECK(s.format_value(1, 4) == "4");
}

namespace {
std::string named_error(const std::vector<std::pair<std::string, std::string>>& values) {
  try {
    theta_of_named(issue_space(), values, "--param");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST_CASE("θ of name=value texts (observe new --param, Python's tell_point): each parameter once, fixed optional") {
  const SearchSpace s = issue_space();
  const Vec t = theta_of_named(
      s, {{"solver", "mpc"}, {"lr", "0.001"}, {"waypoints", "4"}, {"step", "16"}, {"gain", "-0.5"}}, "--param");
  Vec expected(6);
  expected << 0.001, 4, 16, 2, -0.5, 3;  // the category by its index; the fixed value kept
  CHECK(t == expected);
  const std::vector<std::pair<std::string, std::string>> good = {
      {"lr", "0.001"}, {"waypoints", "4"}, {"step", "16"}, {"solver", "lqr"}, {"gain", "0"}};
  auto with = [&](std::pair<std::string, std::string> extra, const std::string& drop = "") {
    std::vector<std::pair<std::string, std::string>> v;
    for (const auto& p : good)
      if (p.first != drop) v.push_back(p);
    if (!extra.first.empty()) v.push_back(extra);
    return v;
  };
  CHECK(named_error(with({"horizon", "3"})).empty());
  CHECK(named_error(with({"horizon", "4"})).find("--param: parameter 'horizon' is fixed at 3") == 0);
  CHECK(named_error(with({"gainn", "1"})).find("no parameter 'gainn'") != std::string::npos);
  CHECK(named_error(with({"gainn", "1"})).find("did you mean 'gain'?") != std::string::npos);
  CHECK(named_error(with({"gain", "1"})).find("'gain' is given twice") != std::string::npos);
  CHECK(named_error(with({}, "step")).find("missing step") != std::string::npos);
  CHECK(named_error(with({"solver", "lqe"}, "solver")).find("did you mean 'lqr'?") != std::string::npos);
  CHECK(named_error(with({"waypoints", "4.5"}, "waypoints")).find("'waypoints' is an int parameter") !=
        std::string::npos);
  CHECK(named_error(with({}, "step")).find("nothing written") != std::string::npos);
}

TEST_CASE("each bad parameter declaration is refused at its key") {
  CHECK(error_of("- {name: a, type: real, low: 1, high: 1}").find("p.yaml:1:39: key '[0].high'") == 0);
  CHECK(error_of("- {name: a, type: real, low: 2, high: 1}").find("must exceed low") != std::string::npos);
  CHECK(error_of("- {name: a, type: int, low: 3, high: 3}").find("must exceed low (3); a parameter held at one value "
                                                                   "is {name: a, type: fixed, value: 3}") !=
        std::string::npos);
  CHECK(error_of("- {name: a, type: real, low: 0, high: 1, log: true}").find("p.yaml:1:30") == 0);
  CHECK(error_of("- {name: a, type: real, low: 0, high: 1, log: true}").find("log-scaled parameter needs low > 0") != std::string::npos);
  CHECK(error_of("- {name: a, type: int, low: 0.5, high: 3}").find("integer bounds") != std::string::npos);
  CHECK(error_of("- {name: a, type: categorical, choices: []}").find("non-empty list") != std::string::npos);
  CHECK(error_of("- {name: a, type: categorical, choices: [x, y, x]}").find("duplicate choice 'x'") != std::string::npos);
  // A label with a newline and one with a backslash and an n are both written "new\nline" in trials.csv (session 45).
  CHECK(error_of("- {name: a, type: categorical, choices: [b, 'new\\nline', \"new\\nline\"]}")
            .find("choices 2 and 3 are both written 'new\\nline' in trials.csv") != std::string::npos);
  CHECK(error_of("- {name: a, type: real, low: 0, high: 1}\n- {name: a, type: int, low: 0, high: 3}")
            .find("p.yaml:2:10: key '[1].name': duplicate parameter name 'a'") == 0);
  CHECK(error_of("- {name: a, type: rael, low: 0, high: 1}").find("did you mean 'real'") != std::string::npos);
  CHECK(error_of("- {name: a, type: real, low: 0, hihg: 1}").find("needs high") != std::string::npos);
  CHECK(error_of("- {name: a, type: real, low: 0, high: 1, choices: [x]}").find("unknown key") != std::string::npos);
  CHECK(error_of("- {name: a, type: fixed, value: 1}").find("every parameter is fixed") != std::string::npos);
  CHECK(error_of("- {name: 2a, type: real, low: 0, high: 1}").find("starts with a letter") != std::string::npos);
  CHECK(error_of("- {type: real, low: 0, high: 1}").find("needs a name") != std::string::npos);
  CHECK(error_of("{}").find("non-empty list of parameters") != std::string::npos);
}

TEST_CASE("constraints parse into Σ a·v ≤ b, whatever side the terms are on") {
  const SearchSpace s = issue_space();
  const LinearConstraint c = parse_linear_constraint("gain + 2*waypoints - 0.5 horizon <= 5.5", s.parameters());
  REQUIRE(c.terms.size() == 3);
  CHECK(c.bound == 5.5);
  const LinearConstraint d = parse_linear_constraint("3 >= waypoints*2 - gain + 1", s.parameters());
  // 2·w − g + 1 ≤ 3  →  2·w − g ≤ 2
  CHECK(d.bound == 2);
  for (const auto& [i, a] : d.terms) CHECK(a == (i == 1 ? 2.0 : -1.0));
  const LinearConstraint e = parse_linear_constraint("gain >= -0.5", s.parameters());
  CHECK(e.bound == 0.5);
  CHECK(e.terms[0].second == -1.0);
  // Strict over integers (session 23: "n < 3" allowed n = 3): whole terms, so Σ < b is Σ ≤ ⌈b⌉ − 1.
  CHECK(parse_linear_constraint("waypoints < 3", s.parameters()).bound == 2);
  CHECK(parse_linear_constraint("waypoints < 3.5", s.parameters()).bound == 3);
  CHECK(parse_linear_constraint("waypoints > 4", s.parameters()).bound == -5);       // −w ≤ −5: w ≥ 5
  CHECK(parse_linear_constraint("2*waypoints + horizon < 9", s.parameters()).bound == 8);  // horizon is a whole 3
  // With a real parameter or a fractional coefficient the boundary has no volume: `<` is `<=`.
  CHECK(parse_linear_constraint("waypoints + gain < 3", s.parameters()).bound == 3);
  CHECK(parse_linear_constraint("0.5*waypoints < 3", s.parameters()).bound == 3);
}

TEST_CASE("each bad constraint is refused with the reason") {
  CHECK(constraint_error("gain + wayponts <= 3").find("unknown parameter 'wayponts'") != std::string::npos);
  CHECK(constraint_error("gain + wayponts <= 3").find("did you mean 'waypoints'") != std::string::npos);
  CHECK(constraint_error("gain + waypoints").find("no comparison") != std::string::npos);
  CHECK(constraint_error("gain = 1").find("an equality") != std::string::npos);
  CHECK(constraint_error("gain + * 2 <= 1").find("character 8") != std::string::npos);
  CHECK(constraint_error("gain ^ 2 <= 1").find("unexpected character '^'") != std::string::npos);
  CHECK(constraint_error("gain - gain <= 1").find("names no parameter") != std::string::npos);
  SearchSpace s = issue_space();
  CHECK_THROWS_WITH_AS(s.add_constraint(parse_linear_constraint("solver <= 1", s.parameters())),
                       doctest::Contains("is categorical"), ConfigError);
  CHECK_THROWS_WITH_AS(s.add_constraint(parse_linear_constraint("lr <= 0.01", s.parameters())),
                       doctest::Contains("log-scaled"), ConfigError);
}

TEST_CASE("admissible points satisfy every constraint; an empty feasible set is detected") {
  SearchSpace s(std::vector<Parameter>{
      Parameter{"t1", ParameterType::Real, 0, 4, false, {}, 0}, Parameter{"t2", ParameterType::Real, 0, 4, false, {}, 0},
      Parameter{"n", ParameterType::Int, 0, 5, false, {}, 0}});
  s.add_constraint(parse_linear_constraint("t1 + t2 + n <= 5.5", s.parameters()));
  s.add_constraint(parse_linear_constraint("t1 - t2 >= -1", s.parameters()));
  REQUIRE(s.finalize());
  Rng rng(5);
  int repaired = 0;
  for (int k = 0; k < 2000; ++k) {
    const Vec x = rng.uniform_vec(s.encoded_dim());
    const Vec a = s.admissible(x);
    const Vec theta = s.decode(a);
    std::string why;
    CHECK_MESSAGE(s.contains(theta, &why), why);
    CHECK(s.admissible(a) == a);
    repaired += !s.satisfies_constraints(s.round_discrete(x));
  }
  CHECK(repaired > 100);  // the test exercised the repair
  // A feasible point is kept as it is.
  const Vec inside = s.encode((Vec(3) << 1.0, 1.5, 2).finished());
  CHECK(s.admissible(inside) == inside);

  SearchSpace empty(std::vector<Parameter>{Parameter{"t1", ParameterType::Real, 0, 4, false, {}, 0},
                                           Parameter{"t2", ParameterType::Real, 0, 4, false, {}, 0}});
  empty.add_constraint(parse_linear_constraint("t1 + t2 >= 9", empty.parameters()));
  CHECK_FALSE(empty.finalize());
  // The relaxation is feasible (n ∈ [1.5, 1.75]) but no integer is.
  SearchSpace no_integer(std::vector<Parameter>{Parameter{"n", ParameterType::Int, 0, 5, false, {}, 0},
                                                Parameter{"g", ParameterType::Real, 0, 1, false, {}, 0}});
  no_integer.add_constraint(parse_linear_constraint("2*n >= 3", no_integer.parameters()));
  no_integer.add_constraint(parse_linear_constraint("2*n <= 3.5", no_integer.parameters()));
  CHECK_FALSE(no_integer.finalize());
}

TEST_CASE("an equality written as two inequalities is searched along, not collapsed to one point") {
  // "a + b <= 1" and "a + b >= 1", as the parser's error for `==` advises: the repair kept 1e-9 inside the relaxed
  // polytope, which is empty here, and every point fell back to one pooled point (a whole study ran at x = y = 0.5,
  // even n never changed; red team, session 26).
  SearchSpace s(std::vector<Parameter>{Parameter{"x", ParameterType::Real, 0, 1, false, {}, 0},
                                       Parameter{"y", ParameterType::Real, 0, 1, false, {}, 0},
                                       Parameter{"n", ParameterType::Int, 0, 5, false, {}, 0}});
  s.add_constraint(parse_linear_constraint("x + y <= 1", s.parameters()));
  s.add_constraint(parse_linear_constraint("x + y >= 1", s.parameters()));
  REQUIRE(s.finalize());
  Rng rng(3);
  std::set<double> xs, ns;
  for (int k = 0; k < 50; ++k) {
    const Vec theta = s.decode(s.admissible(rng.uniform_vec(s.encoded_dim())));
    std::string why;
    CHECK_MESSAGE(s.contains(theta, &why), why);
    CHECK(std::abs(theta[0] + theta[1] - 1.0) < 1e-12);
    xs.insert(theta[0]);
    ns.insert(theta[2]);
  }
  CHECK(xs.size() >= 40);  // spread along the line (the nearest point of it to each draw)
  CHECK(ns.size() == 6);   // a parameter in no constraint keeps every value
}

TEST_CASE("constraint tolerance: relative to the terms at θ, not to the parameters' ranges") {
  // f1, f2 in [0, 1e9] Hz with f1 − f2 ≥ 1: 1e-9 of the range is 1 Hz, the whole margin, and f1 = f2 was accepted
  // (red team, session 26). Rounding of a decoded θ (a few ulps of the range) stays accepted.
  SearchSpace s(std::vector<Parameter>{Parameter{"f1", ParameterType::Real, 0, 1e9, false, {}, 0},
                                       Parameter{"f2", ParameterType::Real, 0, 1e9, false, {}, 0}});
  s.add_constraint(parse_linear_constraint("f1 - f2 >= 1", s.parameters()));
  REQUIRE(s.finalize());
  std::string why;
  CHECK_FALSE(s.contains((Vec(2) << 5e8, 5e8).finished(), &why));
  // By how much, in the user's terms ("gain - 0.5*t1 >= -1 is violated (1.4 > 1)" read the negated row).
  CHECK(why == "constraint 'f1 - f2 >= 1' is violated by 1");
  CHECK(s.contains((Vec(2) << 5e8 + 1, 5e8).finished()));
  CHECK(s.contains((Vec(2) << 1e9, 1e9 - 1 - 1e-6).finished()));  // within the rounding of the range
  // x, y ≥ 0 with x + y ≤ −1e-12: empty (the range-scaled tolerance accepted x = y = 0).
  SearchSpace empty(std::vector<Parameter>{Parameter{"x", ParameterType::Real, 0, 1, false, {}, 0},
                                           Parameter{"y", ParameterType::Real, 0, 1, false, {}, 0}});
  empty.add_constraint(parse_linear_constraint("x + y <= -1e-12", empty.parameters()));
  CHECK_FALSE(empty.finalize());
  // Farads (session 22): a relative tolerance, not an absolute 1e-9.
  SearchSpace farads(std::vector<Parameter>{Parameter{"c1", ParameterType::Real, 0, 1e-9, false, {}, 0},
                                            Parameter{"c2", ParameterType::Real, 0, 1e-9, false, {}, 0}});
  farads.add_constraint(parse_linear_constraint("c1 + c2 <= 1e-10", farads.parameters()));
  REQUIRE(farads.finalize());
  CHECK_FALSE(farads.contains((Vec(2) << 1e-10, 1e-10).finished()));
  CHECK(farads.contains((Vec(2) << 5e-11, 5e-11).finished()));
}

TEST_CASE("constraints: file:line:col for a bad constraint and for an empty feasible set") {
  SearchSpace s = issue_space();
  const ConfigNode bad = ConfigNode::parse("- \"gain <= 1\"\n- \"solver + gain <= 1\"\n", "c.yaml");
  CHECK_THROWS_WITH_AS(add_constraints(s, bad), doctest::Contains("c.yaml:2:3: key '[1]'"), ConfigError);
  SearchSpace t = issue_space();
  const ConfigNode empty = ConfigNode::parse("- \"gain >= 0.5\"\n- \"gain <= 0.25\"\n", "c.yaml");
  CHECK_THROWS_WITH_AS(add_constraints(t, empty), doctest::Contains("no admissible point satisfies every constraint"),
                       ConfigError);
}

namespace {
/// A smooth stand-in surrogate: mean = Σ_k sin(3 x_k) + x_k², variance 0.1 + x_0², with analytic gradients.
class SmoothModel final : public Surrogate {
 public:
  FitReport fit(const Dataset& d, Rng&) override { return condition(d); }
  FitReport condition(const Dataset& d) override {
    seen = d.X;
    return {};
  }
  Prediction predict(const Vec& x, bool g) const override {
    Prediction p;
    p.mean = (3 * x.array()).sin().sum() + x.squaredNorm();
    p.latent_var = 0.1 + x[0] * x[0];
    if (g) {
      p.d_mean = (3 * (3 * x.array()).cos() + 2 * x.array()).matrix();
      p.d_latent_var = Vec::Zero(x.size());
      p.d_latent_var[0] = 2 * x[0];
      p.d_log_noise_mean = p.d_log_noise_var = Vec::Zero(x.size());
    }
    return p;
  }
  double signal_variance() const override { return 1; }
  Hyperparameters hyperparameters() const override { return {}; }
  void set_hyperparameters(const Hyperparameters&) override {}
  bool ready() const override { return true; }
  Mat seen;
};
}  // namespace

TEST_CASE("the rounded surrogate is constant between admissible values and keeps the continuous gradient") {
  auto space = std::make_shared<const SearchSpace>(issue_space());
  auto inner = std::make_unique<SmoothModel>();
  SmoothModel* raw = inner.get();
  RoundedSurrogate model(std::move(inner), space);
  Rng rng(9);
  Vec base = space->admissible(rng.uniform_vec(space->encoded_dim()));
  // Moving an integer coordinate within its cell, or a category's scores without changing the argmax, changes
  // nothing; the prediction equals the inner model's at the admissible point.
  const double at = raw->predict(base, false).mean;
  for (int k = 0; k < 50; ++k) {
    Vec x = base;
    x[1] = std::clamp(base[1] + (rng.uniform() - 0.5) / 8 * 0.98, 0.0, 1.0);  // waypoints: cells of width 1/8
    x.segment(3, 3) = 0.5 * base.segment(3, 3) + 0.4 * rng.uniform_vec(3).cwiseProduct(base.segment(3, 3));
    CHECK(model.predict(x, false).mean == at);
  }
  // Gradient: zero in the discrete coordinates, the inner model's (checked by central differences) elsewhere.
  const Prediction p = model.predict(base, true);
  for (Index k = 0; k < base.size(); ++k) {
    if (space->is_discrete_coordinate(k)) {
      CHECK(p.d_mean[k] == 0);
      continue;
    }
    Vec a = base, b = base;
    a[k] -= 1e-6;
    b[k] += 1e-6;
    const double fd = (model.predict(b, false).mean - model.predict(a, false).mean) / 2e-6;
    CHECK(p.d_mean[k] == doctest::Approx(fd).epsilon(1e-6));
  }
  // The data reach the inner model rounded.
  Dataset d = Dataset::empty(space->encoded_dim());
  d.add(rng.uniform_vec(space->encoded_dim()), 1.0);
  model.condition(d);
  CHECK(Vec(raw->seen.row(0).transpose()) == space->round_discrete(d.X.row(0).transpose()));
}

TEST_CASE("a region in a typed space: neighbouring integers and every category stay reachable; constraints kept") {
  auto space = std::make_shared<SearchSpace>(issue_space());
  space->add_constraint(parse_linear_constraint("gain + 0.25*waypoints <= 1.5", space->parameters()));
  REQUIRE(space->finalize());
  const SharedSpace shared = space;
  Vec theta(6);
  theta << 1e-3, 5, 16, 1, -0.5, 3;
  const Vec c = shared->encode(theta);
  // A trust region far smaller than one integer's cell (1/8 for waypoints).
  const Box tiny{(c.array() - 1e-3).matrix(), (c.array() + 1e-3).matrix()};
  ConstrainedRegion region(std::make_unique<BoxRegion>(tiny), shared);
  const Box& b = region.bounds();
  for (const double w : {4.0, 5.0, 6.0}) {
    Vec t = theta;
    t[1] = w;
    CHECK(b.contains(shared->encode(t), 1e-12));  // waypoints 4 and 6 reachable
  }
  CHECK(b.lower.segment(3, 3) == Vec::Zero(3));  // every category
  CHECK(b.upper.segment(3, 3) == Vec::Ones(3));
  CHECK(b.lower[0] == tiny.lower[0]);  // continuous coordinates as the inner region's
  CHECK(b.upper[6] == tiny.upper[6]);
  // The constraint: c(x) ≥ 0 exactly where the decoded θ satisfies it (away from rounding of the integer).
  CHECK(region.has_constraint());
  Rng rng(2);
  for (int k = 0; k < 200; ++k) {
    const Vec x = shared->round_discrete(rng.uniform_vec(shared->encoded_dim()));
    const Vec t = shared->decode(x);
    const double lhs = t[4] + 0.25 * t[1];
    if (std::abs(lhs - 1.5) < 1e-9) continue;
    CHECK((region.constraint(x, nullptr) >= 0) == (lhs <= 1.5));
    Vec g;
    region.constraint(x, &g);
    Vec a = x, d = x;
    a[6] -= 1e-6;  // gain's coordinate (linear: the gradient is exact)
    d[6] += 1e-6;
    CHECK(g[6] == doctest::Approx((region.constraint(d, nullptr) - region.constraint(a, nullptr)) / 2e-6).epsilon(1e-5));
  }
}

TEST_CASE("int bounds beyond 2^53 are refused: not every integer there is a double (audit11a)") {
  // [-2^63, 2^63 - 1] ran and wrote n = 7.14865037247871e+18 to trials.csv.
  CHECK(error_of("- {name: n, type: int, low: -9223372036854775808, high: 10}")
            .find("parameter 'n' (int): -9223372036854775808 is beyond ±2^53 = 9007199254740992") !=
        std::string::npos);
  CHECK(error_of("- {name: n, type: int, low: -9007199254740992, high: 9007199254740992}").empty());
  // Tested as written: 2^53 + 1 read as a double is 2^53 (red team, session 34).
  CHECK(error_of("- {name: n, type: int, low: 0, high: 9007199254740993}")
            .find("9007199254740993 is beyond ±2^53") != std::string::npos);
  CHECK(error_of("- {name: n, type: int, low: -9007199254740993, high: 0}")
            .find("-9007199254740993 is beyond ±2^53") != std::string::npos);
}

TEST_CASE("a quoted fixed value is a label, as YAML reads it; an unquoted number is a number") {
  // `value: "3.0"` was sent to the command as the number 3 (audit, session 44).
  const SearchSpace s = parse_search_space(ConfigNode::parse(
      "- {name: a, type: real, low: 0, high: 1}\n- {name: m, type: fixed, value: \"3.0\"}\n"
      "- {name: n, type: fixed, value: 3.0}\n- {name: q, type: fixed, value: '010'}\n",
      "p.yaml"));
  REQUIRE(s.size() == 4);
  CHECK(s.parameters()[1].choices == std::vector<std::string>{"3.0"});
  CHECK(s.parameters()[2].choices.empty());
  CHECK(s.parameters()[2].value == 3.0);
  CHECK(s.parameters()[3].choices == std::vector<std::string>{"010"});
}

TEST_CASE("a rounded point outside the constraints is scored at its repaired point, the one evaluated") {
  // Audit, session 47: x = 0.6, n = 6.6 satisfies "x + n <= 7.2" unrounded; the model scored it as n = 7 (which
  // violates it) while the suggestion became the repaired n = 6, and bo proposed that point 23 times in 24.
  auto space = std::make_shared<SearchSpace>(std::vector<Parameter>{
      Parameter{"x", ParameterType::Real, -2, 3, false, {}, 0}, Parameter{"n", ParameterType::Int, 1, 10, false, {}, 0}});
  space->add_constraint(parse_linear_constraint("x + n <= 7.2", space->parameters()));
  REQUIRE(space->finalize());
  auto inner = std::make_unique<SmoothModel>();
  SmoothModel* raw = inner.get();
  RoundedSurrogate model(std::move(inner), space);
  // Unit coordinates of x = 0.5 and n = 6.6 (an int's coordinate spans [low − ½, high + ½]).
  const Vec x = (Vec(2) << (0.5 + 2) / 5, (6.6 - 0.5) / 10).finished();
  REQUIRE(space->constraint_slack(x, nullptr) >= 0);               // feasible as the optimizer sees it
  REQUIRE_FALSE(space->satisfies_constraints(space->round_discrete(x)));  // not once rounded
  const Vec evaluated = space->admissible(x);
  CHECK(space->satisfies_constraints(evaluated));
  CHECK(model.predict(x, false).mean == raw->predict(evaluated, false).mean);
  CHECK(model.predict(x, false).mean != raw->predict(space->round_discrete(x), false).mean);
  // A rounded point inside the constraints is scored there, as before.
  const Vec inside = (Vec(2) << (0.1 + 2) / 5, (6.6 - 0.5) / 10).finished();
  REQUIRE(space->satisfies_constraints(space->round_discrete(inside)));
  CHECK(model.predict(inside, false).mean == raw->predict(space->round_discrete(inside), false).mean);
}

TEST_CASE("repair: with the integers rounded, the real parameters are projected, not sent to one stored point") {
  // Audit, session 47: candidates beyond "x + y + h + n <= 6" whose projection put n below its range were all
  // repaired to the one nearest point stored by finalize(); cma_es then measured one θ 16 times in 30.
  SearchSpace s(std::vector<Parameter>{Parameter{"x", ParameterType::Real, 0, 5, false, {}, 0},
                                       Parameter{"y", ParameterType::Real, 0, 5, false, {}, 0},
                                       Parameter{"h", ParameterType::Fixed, 0, 0, false, {}, 3.0},
                                       Parameter{"n", ParameterType::Int, 1, 4, false, {}, 0}});
  s.add_constraint(parse_linear_constraint("x + y + h + n <= 6", s.parameters()));
  REQUIRE(s.finalize());
  Rng rng(2);
  std::set<std::pair<double, double>> repaired;
  int far = 0;
  for (int k = 0; k < 40; ++k) {
    // Far outside: x, y in [3, 5], n's coordinate near its low end.
    const Vec theta_x = (Vec(3) << (3 + 2 * rng.uniform()) / 5, (3 + 2 * rng.uniform()) / 5, 0.05 * rng.uniform())
                            .finished();
    const Vec a = s.admissible(theta_x);
    const Vec theta = s.decode(a);
    std::string why;
    CHECK_MESSAGE(s.contains(theta, &why), why);
    far += !s.satisfies_constraints(s.round_discrete(theta_x));
    repaired.insert({theta[0], theta[1]});
  }
  CHECK(far == 40);
  CHECK(repaired.size() >= 30);  // the nearest feasible point of each, not one for all
}
