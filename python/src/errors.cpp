// varbo's C++ errors as Python exceptions. ConfigError and InputError are ValueErrors; a ConfigError carries the
// file, line, column and key path its message starts with ("file:line:col: key 'a.b': ..."). Interrupted (a stop
// signal during a run) is a KeyboardInterrupt. Every other C++ exception becomes a RuntimeError (pybind11's
// default), so none escapes as a crash.
#include <filesystem>
#include <regex>
#include <string>

#include "common.hpp"
#include "varbo/errors.hpp"
#include "varbo/interrupt.hpp"

namespace varbo::python {

namespace {

PyObject* g_error = nullptr;
PyObject* g_config_error = nullptr;
PyObject* g_unknown_component = nullptr;
PyObject* g_input_error = nullptr;
PyObject* g_plugin_error = nullptr;
PyObject* g_numerical_error = nullptr;

PyObject* new_exception(py::module_& m, const char* name, std::initializer_list<PyObject*> bases, const char* doc) {
  py::tuple b(bases.size());
  std::size_t i = 0;
  for (PyObject* p : bases) b[i++] = py::reinterpret_borrow<py::object>(p);
  const std::string full = std::string("varbo.") + name;
  PyObject* type = PyErr_NewExceptionWithDoc(full.c_str(), doc, b.ptr(), nullptr);
  if (!type) throw py::error_already_set();
  m.add_object(name, py::reinterpret_borrow<py::object>(type));
  return type;
}

/// Raises `type` with the message; for a message "file:line:col: key 'path': ..." sets file, line, column and
/// key on the instance (None where absent).
void raise_located(PyObject* type, const std::string& message) {
  static const std::regex located(R"(^(.*?):(\d+):(\d+): (?:key '([^']*)': )?)");
  py::object exc = py::reinterpret_borrow<py::object>(type)(message);
  std::smatch mt;
  py::object file = py::none(), line = py::none(), col = py::none(), key = py::none();
  if (std::regex_search(message, mt, located)) {
    file = py::str(mt[1].str());
    line = py::int_(std::stol(mt[2].str()));
    col = py::int_(std::stol(mt[3].str()));
    if (mt[4].matched) key = py::str(mt[4].str());
  }
  exc.attr("file") = file;
  exc.attr("line") = line;
  exc.attr("column") = col;
  exc.attr("key") = key;
  PyErr_SetObject(type, exc.ptr());
}

}  // namespace

void bind_errors(py::module_& m) {
  g_error = new_exception(m, "Error", {PyExc_Exception}, "Base of every error varbo raises.");
  g_config_error = new_exception(
      m, "ConfigError", {g_error, PyExc_ValueError},
      "A configuration value is missing, unknown, of the wrong type or out of range. Attributes: file, line, "
      "column (1-based, None when unknown) and key (the key path, e.g. 'algorithm.acquisition.xi').");
  g_unknown_component = new_exception(m, "UnknownComponentError", {g_config_error},
                                       "A component name that no loaded plugin provides.");
  g_input_error = new_exception(m, "InputError", {g_error, PyExc_ValueError},
                                "Bad input data: an unknown trial id, a non-finite cost, a missing study file, ...");
  g_plugin_error = new_exception(m, "PluginLoadError", {g_error},
                                 "A plugin library could not be loaded (not a varbo plugin, wrong ABI, ...).");
  g_numerical_error = new_exception(m, "NumericalError", {g_error, PyExc_ArithmeticError},
                                    "Numerical trouble: a model that cannot be fitted on the data given.");
  py::register_exception_translator([](std::exception_ptr p) {
    if (!p) return;
    try {
      std::rethrow_exception(p);
    } catch (const UnknownComponentError& e) {
      raise_located(g_unknown_component, e.what());
    } catch (const ConfigError& e) {
      raise_located(g_config_error, e.what());
    } catch (const InputError& e) {
      raise_located(g_input_error, e.what());
    } catch (const TaskSetupError& e) {  // the task cannot run at all (exit 126/127): bad input, as before
      PyErr_SetString(g_input_error, e.what());
    } catch (const PluginLoadError& e) {
      PyErr_SetString(g_plugin_error, e.what());
    } catch (const NumericalError& e) {
      PyErr_SetString(g_numerical_error, e.what());
    } catch (const Interrupted& e) {
      ReleasedGil::clear_interrupt();  // the next call waits again unless another Ctrl-C comes
      PyErr_SetString(PyExc_KeyboardInterrupt, e.what());
    } catch (const Error& e) {
      PyErr_SetString(g_error, e.what());
    } catch (const std::filesystem::filesystem_error& e) {
      // A path the system refuses (symlink loop, name too long): bad input, not a RuntimeError.
      const std::string msg = e.path1().string() + ": " + e.code().message();
      PyErr_SetString(g_input_error, msg.c_str());
    }
  });
}

}  // namespace varbo::python
