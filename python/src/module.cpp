// The compiled part of the Python package `varbo` (varbo/_varbo*.so); varbo/__init__.py is the public surface.
#include "common.hpp"
#include "varbo/interrupt.hpp"
#include "varbo/version.hpp"

PYBIND11_MODULE(_varbo, m) {
  using namespace varbo::python;
  m.doc() = "varbo's C++ engine (the SDK and varbo::Study); import varbo instead";
  m.attr("__version__") = VARBO_VERSION_STRING;
  bind_errors(m);
  bind_registry(m);
  bind_study(m);
  bind_minimize(m);
  bind_fit(m);
  bind_algorithm(m);
  py::module_::import("atexit").attr("register")(py::cpp_function([] { ReleasedGil::at_exit(); }));
  // Python keeps SIGINT to itself: a varbo wait asks the interpreter whether a Ctrl-C came (common.hpp).
  ReleasedGil::main_thread_ident = py::cast<unsigned long>(
      py::module_::import("threading").attr("main_thread")().attr("ident"));
  varbo::set_host_interrupt_poll(&ReleasedGil::interrupt_poll);
}
