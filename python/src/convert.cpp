// Conversions between varbo's types and Python objects.
#include <unistd.h>

#include <csignal>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "common.hpp"
#include "varbo/csv.hpp"
#include "varbo/errors.hpp"
#include "varbo/named_values.hpp"

namespace varbo::python {

namespace {
/// A Python str as UTF-8, or an InputError naming the argument: a lone surrogate (what os.fsdecode makes of a byte
/// that is not UTF-8) cannot be encoded, and pybind11's cast said only "Unable to cast Python instance to C++ type"
/// (red team, session 31).
std::string utf8_of(const py::handle& s, const std::string& what) {
  Py_ssize_t size = 0;
  const char* data = PyUnicode_AsUTF8AndSize(s.ptr(), &size);
  if (data == nullptr) {
    PyErr_Clear();
    const py::object shown = py::reinterpret_steal<py::object>(PyObject_ASCII(s.ptr()));  // ascii(s)
    if (!shown) PyErr_Clear();
    throw InputError(fmt::format("{}: {} is not valid text (it holds a lone surrogate, e.g. from os.fsdecode of a "
                                 "byte that is not UTF-8); nothing written",
                                 what, shown ? py::cast<std::string>(shown) : std::string("a str")));
  }
  return std::string(data, static_cast<std::size_t>(size));
}
}  // namespace

py::array_t<double> to_array(const Vec& v) {
  py::array_t<double> a(v.size());
  std::copy(v.data(), v.data() + v.size(), a.mutable_data());
  return a;
}

py::array_t<double> to_array(const Mat& m) {
  py::array_t<double> a({m.rows(), m.cols()});
  auto r = a.mutable_unchecked<2>();
  for (Index i = 0; i < m.rows(); ++i)
    for (Index j = 0; j < m.cols(); ++j) r(i, j) = m(i, j);
  return a;
}

Vec to_vec(const py::handle& obj, const std::string& what) {
  py::array_t<double, py::array::c_style | py::array::forcecast> a;
  try {
    a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(obj);
  } catch (const py::error_already_set&) {
  }
  if (!a || a.ndim() > 1)
    throw InputError(fmt::format("{}: expected a sequence of numbers (a 1-D array)", what));
  Vec v(a.size());
  std::copy(a.data(), a.data() + a.size(), v.data());
  return v;
}

Mat to_mat(const py::handle& obj, const std::string& what) {
  py::array_t<double, py::array::c_style | py::array::forcecast> a;
  try {
    a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(obj);
  } catch (const py::error_already_set&) {
  }
  if (!a || a.ndim() != 2)
    throw InputError(fmt::format("{}: expected a 2-D array of numbers (one row per point)", what));
  Mat m(a.shape(0), a.shape(1));
  auto r = a.unchecked<2>();
  for (Index i = 0; i < m.rows(); ++i)
    for (Index j = 0; j < m.cols(); ++j) m(i, j) = r(i, j);
  return m;
}

namespace {
/// An int parameter's value, and a fixed one without a fraction (`value: 3`): an int, as the external command's
/// JSON gives it (json.loads reads 3 as int); a fixed 3 arrived as 3.0, and `range(n)` failed on it.
bool is_whole(const ParamValue& v) {
  const bool integral = v.type == ParameterType::Int || (v.type == ParameterType::Fixed && v.number == std::round(v.number));
  return integral && std::abs(v.number) < 9e15;
}
}  // namespace

py::dict params_of(const Vec& theta, const std::vector<std::string>& names, const SearchSpace* space) {
  py::dict d;
  if (space && static_cast<std::size_t>(theta.size()) == space->size()) {
    const Params p = space->params(theta);
    for (std::size_t i = 0; i < p.names.size(); ++i) {
      const ParamValue& v = p.values[i];
      py::str key(p.names[i]);
      if (v.is_label())
        d[key] = py::str(v.label);
      else if (is_whole(v))
        d[key] = py::int_(static_cast<long long>(std::llround(v.number)));
      else
        d[key] = py::float_(v.number);
    }
    return d;
  }
  for (Index i = 0; i < theta.size(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    d[py::str(k < names.size() ? names[k] : fmt::format("x{}", i + 1))] = theta[i];
  }
  return d;
}

namespace {
py::object number_or_none(double v) { return std::isnan(v) ? py::object(py::none()) : py::object(py::float_(v)); }
}  // namespace

py::dict trial_dict(const TrialRecord& t, const std::vector<std::string>& names, const SearchSpace* space) {
  py::dict d;
  d["id"] = t.id;
  d["state"] = state_name(t.state);
  d["phase"] = t.phase;
  d["params"] = params_of(t.theta, names, space);
  d["x"] = to_array(t.theta);
  d["x_unit"] = to_array(t.x);
  d["cost"] = number_or_none(t.cost);
  py::dict comps;
  for (const auto& [name, v] : t.components) comps[py::str(name)] = v;
  d["components"] = comps;
  d["error"] = t.error;
  d["worker"] = t.worker;
  d["created_at"] = t.created_at;
  d["finished_at"] = t.finished_at;
  d["fit_seconds"] = t.fit_seconds;
  d["acquisition_seconds"] = t.acquisition_seconds;
  d["evaluation_seconds"] = t.evaluation_seconds;
  return d;
}

namespace {
/// A user's value as the text `--param name=value` would carry: a label as is, an integer exactly, a real with 17
/// significant digits (so the parsed double is the one given).
std::string value_text(const py::handle& given, const std::string& what, const std::string& name) {
  if (py::isinstance<py::str>(given)) return utf8_of(given, fmt::format("{}: parameter '{}'", what, name));
  const py::module_ np = py::module_::import("numpy");
  py::object v = py::reinterpret_borrow<py::object>(given);
  if (py::isinstance(v, np.attr("ndarray"))) {
    // A 0-d array is its element; any other array is not one value. (An array has __index__ when it holds one
    // integer-like element, and was once read as an int: np.array(2.7) became 2.)
    if (py::cast<int>(v.attr("ndim")) != 0)
      throw InputError(fmt::format("{}: parameter '{}': expected a number or a label (str), got an array of shape {}; "
                                   "nothing written",
                                   what, name, py::cast<std::string>(py::str(v.attr("shape")))));
    v = v.attr("item")();
    if (py::isinstance<py::str>(v)) return utf8_of(v, fmt::format("{}: parameter '{}'", what, name));  // its label
  }
  const bool boolean = py::isinstance<py::bool_>(v) || py::isinstance(v, np.attr("bool_"));
  // Integers exactly (Python's and NumPy's integer types); a bool is not a number here.
  if (!boolean && (py::isinstance<py::int_>(v) || py::isinstance(v, np.attr("integer"))))
    return py::cast<std::string>(py::str(py::int_(v)));
  if (!boolean) {
    try {
      return exact(py::cast<double>(v));
    } catch (const py::cast_error&) {
    }
  }
  throw InputError(fmt::format("{}: parameter '{}': expected a number or a label (str), got {} (type {}); nothing "
                               "written",
                               what, name, py::cast<std::string>(py::repr(v)),
                               py::cast<std::string>(v.get_type().attr("__name__"))));
}
}  // namespace

Vec theta_of_mapping(const py::handle& mapping, const SearchSpace* space, const Box& box,
                     const std::vector<std::string>& names, const std::string& what) {
  if (!py::isinstance<py::dict>(mapping)) throw InputError(fmt::format("{}: expected a dict {{name: value}}", what));
  std::vector<std::pair<std::string, std::string>> values;
  for (const auto& [k, v] : py::reinterpret_borrow<py::dict>(mapping)) {
    if (!py::isinstance<py::str>(k)) throw InputError(fmt::format("{}: every parameter name must be a str", what));
    const auto name = utf8_of(k, what + ": a parameter name");
    // A categorical parameter declared with `choices: [True, False]` has the labels "true" and "false" (YAML's
    // spelling): True given for it is that label. It was refused as "got True (type bool)" (red team, session 23).
    if (space && (py::isinstance<py::bool_>(v) || py::isinstance(v, py::module_::import("numpy").attr("bool_")))) {
      const auto& ps = space->parameters();
      const auto it = std::find_if(ps.begin(), ps.end(), [&](const Parameter& p) { return p.name == name; });
      const std::string label = py::cast<bool>(v) ? "true" : "false";
      if (it != ps.end() && it->type == ParameterType::Categorical &&
          std::find(it->choices.begin(), it->choices.end(), label) != it->choices.end()) {
        values.emplace_back(name, label);
        continue;
      }
    }
    values.emplace_back(name, value_text(v, what, name));
  }
  if (space) return theta_of_named(*space, values, what);
  return theta_of_named(SearchSpace::from_box(box, names), values, what);
}

/// The declarations of a typed space as dicts (what `parameters:` says, every default filled in).
py::list parameters_of(const SearchSpace& space) {
  py::list out;
  for (const Parameter& p : space.parameters()) {
    py::dict d;
    d["name"] = p.name;
    d["type"] = parameter_type_name(p.type);
    if (p.type == ParameterType::Real || p.type == ParameterType::Int) {
      d["low"] = p.type == ParameterType::Int ? py::object(py::int_(std::llround(p.low))) : py::object(py::float_(p.low));
      d["high"] = p.type == ParameterType::Int ? py::object(py::int_(std::llround(p.high))) : py::object(py::float_(p.high));
      d["log"] = p.log;
    } else if (p.type == ParameterType::Categorical) {
      d["choices"] = p.choices;
    } else {
      d["value"] = !p.choices.empty() ? py::object(py::str(p.choices[0]))
                   : is_whole(ParamValue{ParameterType::Fixed, p.value, {}})
                       ? py::object(py::int_(static_cast<long long>(std::llround(p.value))))
                       : py::object(py::float_(p.value));
    }
    out.append(d);
  }
  return out;
}

Components components_of(const py::handle& obj) {
  Components out;
  if (obj.is_none()) return out;
  if (!py::isinstance<py::dict>(obj))
    throw InputError("components: expected a dict {name: number}");
  for (const auto& [k, v] : py::reinterpret_borrow<py::dict>(obj)) {
    if (!py::isinstance<py::str>(k)) throw InputError("components: every name must be a string");
    const std::string name = utf8_of(k, "components: a name");
    // A bool is not a number here (as for costs and parameter values): `{"fell": True}` was stored as 1.0.
    if (py::isinstance<py::bool_>(v) || py::isinstance(v, py::module_::import("numpy").attr("bool_")))
      throw InputError(fmt::format("components: '{}' is {} (type bool); expected a number (write 1.0 for a "
                                   "flag you want as a number)",
                                   name, py::cast<std::string>(py::repr(v))));
    double x = 0;
    try {
      x = py::cast<double>(v);
    } catch (const py::cast_error&) {
      throw InputError(fmt::format("components: '{}' must be a number", name));
    }
    out.emplace_back(name, x);
  }
  return out;
}

}  // namespace varbo::python

namespace varbo::python {
void ReleasedGil::pause_forever() { ::pause(); }

int ReleasedGil::interrupt_poll() {
  if (interrupted != 0) return interrupted;
  // Only the main thread runs Python's signal handlers; a wait in another thread is not the Ctrl-C's to end.
  if (PyThread_get_thread_ident() != main_thread_ident) return 0;
  before_taking();  // parks at the program's end, as ~ReleasedGil does
  const PyGILState_STATE gil = PyGILState_Ensure();
  after_taking();
  if (PyErr_CheckSignals() != 0) {
    PyErr_Clear();  // raised again as KeyboardInterrupt when the store's Interrupted reaches Python (errors.cpp)
    interrupted = SIGINT;
  }
  PyGILState_Release(gil);
  return interrupted;
}

void ReleasedGil::at_exit() {
  exiting = true;
  // Threads waiting for the GIL inside ~ReleasedGil passed the check before `exiting`: they take it now, while the
  // interpreter is not yet finalizing (at most 2 s: a thread that never comes back does not hold up the exit).
  Py_BEGIN_ALLOW_THREADS;
  for (int i = 0; i < 2000 && restoring.load() > 0; ++i) ::usleep(1000);
  Py_END_ALLOW_THREADS;
}
}  // namespace varbo::python
