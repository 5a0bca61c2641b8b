#pragma once
// A search space of named, typed parameters (real, int, categorical, fixed; real and int optionally on a log
// scale) with linear constraints, and its encoding into the unit cube the models and optimizers work in.
//
// Two representations of a point:
//  - θ, "user units": one number per parameter in declaration order: the value of a real or int parameter, the
//    index of a category (0-based) in `choices`, the value of a fixed parameter (0 for a fixed label). This is
//    what tasks evaluate, trials.csv shows (with labels) and the study store keeps.
//  - x, "encoded": the unit-cube coordinates of the models: one coordinate per real or int parameter (log
//    parameters in log space), one per category (one-hot), none for a fixed parameter.
//
// Integers and categories follow Garrido-Merchán & Hernández-Lobato 2020 ("Dealing with categorical and
// integer-valued variables in Bayesian optimization with Gaussian processes", Neurocomputing 380): the model
// sees T(x), where T rounds an integer coordinate to its admissible value and replaces a one-hot block by the
// indicator of its largest entry, so the surrogate is constant between admissible values and never believes
// "3.49 waypoints" differs from "3 waypoints". An integer's coordinate covers [low − ½, high + ½] (in log space
// for a log int), so every integer owns an equal share of the cube and a uniform design draws them uniformly.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "varbo/params.hpp"
#include "varbo/types.hpp"

namespace varbo {

struct Parameter {
  std::string name;
  ParameterType type = ParameterType::Real;
  double low = 0, high = 1;           ///< real and int
  bool log = false;                   ///< real and int: modelled in log space (low > 0)
  std::vector<std::string> choices;   ///< categorical: labels; fixed: {label} when the value is a label
  double value = 0;                   ///< fixed: the number (0 when it is a label)
};

/// Σ_j a_j·v_j ≤ b over parameter values v (user units), as declared ("t1 + 2*t2 <= 5.5").
/// The problem with a declaration and the key to blame ("high", "choices", ...); nullopt when it is valid.
struct ParameterProblem {
  std::string key;
  std::string message;
};
std::optional<ParameterProblem> check_parameter(const Parameter& p);

struct LinearConstraint {
  std::vector<std::pair<std::size_t, double>> terms;  ///< (parameter index, coefficient)
  double bound = 0;
  std::string text;                                   ///< as the user wrote it
};

/// Parses "t1 + 2*t2 - 0.5 t3 <= 5.5" (also >=, <, >; numbers and names on both sides) against `params`.
/// Throws ConfigError whose message (without a position: the caller adds it) names the problem: a syntax
/// error with its column, an unknown name (with a suggestion), a categorical or log parameter.
LinearConstraint parse_linear_constraint(const std::string& text, const std::vector<Parameter>& params);

class SearchSpace {
 public:
  SearchSpace() = default;
  /// Checks the declarations (throws ConfigError without a position; parse_search_space adds it).
  explicit SearchSpace(std::vector<Parameter> params);
  /// The space of a plain box: one real parameter per dimension (what a task without `parameters:` has).
  static SearchSpace from_box(const Box& box, const std::vector<std::string>& names);

  /// Adds a constraint (over non-log real/int/fixed parameters). Call finalize() after the last one.
  void add_constraint(LinearConstraint c);
  /// Builds the constraint rows in encoded coordinates and searches admissible feasible points; false when none
  /// is found (an empty feasible set).
  bool finalize();

  const std::vector<Parameter>& parameters() const { return params_; }
  const std::vector<LinearConstraint>& constraints() const { return constraints_; }
  std::size_t size() const { return params_.size(); }
  Index encoded_dim() const { return encoded_dim_; }
  std::vector<std::string> names() const;
  std::optional<std::size_t> index_of(const std::string& name) const;
  /// True when some parameter is int or categorical (the surrogate then needs the rounding transformation).
  bool has_discrete() const;
  bool has_log() const;
  /// `box` (encoded) widened so that from its centre the neighbouring integers (±1) of every int parameter and
  /// every category are inside: a trust region smaller than an integer's cell would otherwise round every
  /// candidate to the same point.
  Box widen_for_discrete(const Box& box) const;
  /// True for an encoded coordinate of an integer or a category.
  bool is_discrete_coordinate(Index k) const { return discrete_[static_cast<std::size_t>(k)] != 0; }
  /// A box over θ (user units): [low, high] for numbers, [0, k−1] for categories, [v, v] for fixed values.
  Box user_box() const;

  /// θ (admissible) of an encoded point: rounds integers, takes the argmax of each one-hot block.
  Vec decode(const Vec& x) const;
  /// The encoded point of an admissible θ (integers at the centre of their cell, categories one-hot).
  Vec encode(const Vec& theta) const;
  /// T(x) of Garrido-Merchán & Hernández-Lobato 2020: integer and categorical coordinates replaced by their
  /// admissible encoding, continuous coordinates untouched (so the gradient there is the model's own).
  Vec round_discrete(const Vec& x) const;
  /// The admissible point to evaluate for an encoded x: round_discrete(clamp(x)) when it satisfies every
  /// constraint; else repaired: projected onto the constraints' polytope, rounded (first to the nearest, then
  /// towards the feasible side), and, if still infeasible, the nearest of the admissible feasible points found by
  /// finalize(). Idempotent. Deterministic.
  Vec admissible(const Vec& x) const;

  /// θ admissible: right size, within bounds, integers integral, categories valid, constraints met (tol in
  /// user units, relative to the constraint's scale). `why` names the first violation.
  bool contains(const Vec& theta, std::string* why = nullptr, double tol = 1e-9) const;
  /// Every constraint satisfied by the encoded point (exactly linear there for non-log parameters).
  bool satisfies_constraints(const Vec& x, double tol = 1e-9) const;
  /// min_j (b_j − a_j·x)/‖a_j‖ in encoded coordinates (≥ 0 inside), with the gradient of the active row.
  double constraint_slack(const Vec& x, Vec* grad) const;
  bool has_constraints() const { return !constraints_.empty(); }

  /// Typed view of θ.
  Params params(const Vec& theta) const;
  /// θ of a typed view (every parameter present; InputError naming the parameter otherwise).
  Vec theta(const Params& p) const;
  /// The value of parameter i from text ("0.001", "4", "lqr"); InputError with the expected form otherwise.
  double parse_value(std::size_t i, const std::string& text) const;
  /// θ_i as text: a label, an integer, or a real with 17 significant digits.
  std::string format_value(std::size_t i, double v) const;

 private:
  void layout();
  double to_coordinate(std::size_t i, double v) const;    ///< real/int value → encoded coordinate
  double from_coordinate(std::size_t i, double u) const;  ///< encoded coordinate → value (int: unrounded)
  Vec repair(const Vec& x) const;

  std::vector<Parameter> params_;
  std::vector<Index> offset_;  ///< first encoded coordinate of each parameter
  std::vector<char> discrete_; ///< per encoded coordinate
  Index encoded_dim_ = 0;
  std::vector<LinearConstraint> constraints_;
  Mat A_;  ///< constraints in encoded coordinates: A x ≤ b
  Vec b_;
  Mat pool_;  ///< admissible feasible encoded points (rows), the repair's last resort
};

/// The space the study's components share (null: a plain box, as before search spaces existed).
using SharedSpace = std::shared_ptr<const SearchSpace>;

/// An optional interface of a Task or an Algorithm, found with dynamic_cast (as ComponentState), so the SDK's
/// Task, Algorithm and BuildContext stay as they were for components that know nothing of typed spaces.
///  - A task that defines typed parameters (the mixed benchmarks) returns them from search_space(); a task that
///    takes them (external) receives the study's `parameters:` through set_search_space() right after it is built.
///    Its domain() is then the space's user_box() and names(); θ holds one value per parameter.
///  - An algorithm receives the study's space (parameters and constraints) through set_search_space() right after
///    it is built, before its first ask(); its unit cube is the space's encoding (dimension encoded_dim()).
class SpaceAware {
 public:
  virtual ~SpaceAware();
  virtual SharedSpace search_space() const { return nullptr; }
  virtual void set_search_space(SharedSpace space) = 0;
};

}  // namespace varbo
