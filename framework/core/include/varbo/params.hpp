#pragma once
// Params: a typed, named view of one point of a search space (what a user's code reads: lr as a double,
// waypoints as an integer, solver as a label). A plain value type: names and values in declaration order.
#include <string>
#include <vector>

namespace varbo {

enum class ParameterType { Real, Int, Categorical, Fixed };
std::string parameter_type_name(ParameterType t);

struct ParamValue {
  ParameterType type = ParameterType::Real;
  double number = 0;    ///< real, int (integral) and numeric fixed values
  std::string label;    ///< categorical and fixed-label values
  bool is_label() const { return !label.empty() || type == ParameterType::Categorical; }
};

class Params {
 public:
  std::vector<std::string> names;
  std::vector<ParamValue> values;

  bool has(const std::string& name) const;
  /// The value; std::out_of_range naming the parameter when absent.
  const ParamValue& at(const std::string& name) const;
  /// A real (or int, or numeric fixed) value; std::invalid_argument for a label.
  double real(const std::string& name) const;
  /// An int value; std::invalid_argument for a non-integral number or a label.
  long integer(const std::string& name) const;
  /// A categorical (or fixed-label) value; std::invalid_argument for a number.
  const std::string& label(const std::string& name) const;
  /// {"lr": 0.001, "waypoints": 4, "solver": "lqr"} as JSON text (ints without a decimal point).
  std::string to_json() const;
};

}  // namespace varbo
