#pragma once
// Shared pieces of the Python bindings: conversions between Eigen/varbo types and Python objects, and the
// process-wide registry the module uses for varbo.plugins(), describe(), fit() and the Optuna sampler.
#include <pybind11/pybind11.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <atomic>
#include <optional>
#include <string>
#include <vector>

#include "varbo/registry.hpp"
#include "varbo/search_space.hpp"
#include "varbo/store.hpp"

namespace varbo::python {

namespace py = pybind11;

/// py::gil_scoped_release, except at interpreter exit: a daemon thread (a live plot, a background optimizer, a
/// Jupyter kernel shutting down) whose varbo call ends after the interpreter began finalizing was ended by CPython
/// with pthread_exit when it took the GIL back; the unwinding through this destructor (noexcept) called
/// std::terminate: "FATAL: exception not rethrown", exit 134 and a core dump (red team, session 30). Such a
/// thread waits here instead until the process is gone. (A thread already waiting for the GIL when finalizing
/// begins is let through by at_exit() first.)
class ReleasedGil {
 public:
  ReleasedGil() : state_(PyEval_SaveThread()) { interrupted = 0; }
  ~ReleasedGil() {
    before_taking();
    PyEval_RestoreThread(state_);
    --restoring;
  }
  /// The guard of a thread about to take the GIL: parks it for good once the program is ending; else counts it
  /// among the threads at_exit() lets through (the caller takes the GIL, then decrements `restoring`).
  static void before_taking() {
    ++restoring;
    if (exiting.load() || finalizing()) {
      --restoring;
      park();
    }
  }
  static void after_taking() { --restoring; }
  /// The host poll of varbo/interrupt.hpp (set at import): a Ctrl-C the interpreter has seen while this call waits
  /// (the study store's wait for its write lock, up to ~10 min while an `sqlite3` shell holds it) ends the wait as a
  /// SIGINT ends `varbo run`'s, and the call raises KeyboardInterrupt (red team, session 46: `tell` ignored Ctrl-C
  /// for as long as the lock was held, then recorded the result and raised). The main thread only (where CPython
  /// runs signal handlers); latched until the next varbo call.
  static int interrupt_poll();
  /// Ends interrupt_poll()'s latch: called where the Interrupted it caused becomes KeyboardInterrupt (errors.cpp).
  static void clear_interrupt() { interrupted = 0; }
  static inline unsigned long main_thread_ident = 0;  ///< PyThread_get_thread_ident() of the importing thread
  /// Never returns: a thread that must not touch Python again waits here until the process is gone.
  [[noreturn]] static void park() {
    for (;;) pause_forever();
  }
  /// Called by an atexit function (module.cpp), before the interpreter finalizes: from then on a thread leaving a
  /// varbo call parks; the threads already waiting for the GIL get it and return while it is still safe.
  static void at_exit();
  ReleasedGil(const ReleasedGil&) = delete;
  ReleasedGil& operator=(const ReleasedGil&) = delete;

 private:
  static bool finalizing() {
#if PY_VERSION_HEX >= 0x030D0000
    return Py_IsFinalizing() != 0;
#else
    return _Py_IsFinalizing() != 0;
#endif
  }
  static void pause_forever();
  static inline std::atomic<bool> exiting{false};
  static inline std::atomic<int> restoring{0};  ///< threads between the check and having the GIL back
  static inline thread_local int interrupted = 0;  ///< interrupt_poll()'s latch for this thread's current call
  PyThreadState* state_;
};

/// py::gil_scoped_acquire with ReleasedGil's guard, for a varbo thread calling back into Python (minimize's
/// objective and callback): a daemon thread inside minimize() when the program ended was ended by CPython with
/// pthread_exit as it took the GIL for the objective, and the unwinding, caught as a failed trial, aborted the
/// process ("FATAL: exception not rethrown", exit 134; red team, session 46). It parks instead, as ReleasedGil's.
class TakenGil {
 public:
  TakenGil() {
    ReleasedGil::before_taking();
    gil_.emplace();
    ReleasedGil::after_taking();
  }
  TakenGil(const TakenGil&) = delete;
  TakenGil& operator=(const TakenGil&) = delete;

 private:
  std::optional<py::gil_scoped_acquire> gil_;
};

/// A 1-D float64 array (a copy).
py::array_t<double> to_array(const Vec& v);
/// A 2-D float64 array (a copy, row-major).
py::array_t<double> to_array(const Mat& m);
/// Any sequence or array of numbers as a vector; `what` names it in the ValueError.
Vec to_vec(const py::handle& obj, const std::string& what);
/// A 2-D array-like (a 1-D one is one row per value when dim == 1, else one row) as a matrix.
Mat to_mat(const py::handle& obj, const std::string& what);
/// {name: value} for a θ in user units: with a typed space (docs/search_space.md) its typed view
/// (SearchSpace::params: int for int parameters, str labels for categories, fixed values included), else floats.
py::dict params_of(const Vec& theta, const std::vector<std::string>& names, const SearchSpace* space = nullptr);
/// Every field of a stored trial, as the dict varbo.Trial is built from.
py::dict trial_dict(const TrialRecord& t, const std::vector<std::string>& names, const SearchSpace* space = nullptr);
/// θ (user units) of a {name: value} mapping given by the user: each value (int, float, str label) is written as
/// text and parsed as `varbo observe new --param name=value` parses it (varbo/named_values.hpp); `space` null:
/// the box of reals `box` named `names`. InputError (a ValueError) naming the parameter otherwise.
Vec theta_of_mapping(const py::handle& mapping, const SearchSpace* space, const Box& box,
                     const std::vector<std::string>& names, const std::string& what);
/// The declarations of a typed space as a list of dicts {name, type, low, high, log | choices | value}.
py::list parameters_of(const SearchSpace& space);
/// Cost components from a dict {name: value} (None or empty: none).
Components components_of(const py::handle& obj);

/// The module's registry: the built-in plugins (next to libvarbo_core), VARBO_PLUGIN_PATH, and what
/// varbo.load_plugin() added. Used (resolve, create) and extended only while holding the GIL, which serializes
/// load_plugin() with every lookup.
const Registry& module_registry();
/// Loads one plugin file into the module's registry and appends it to VARBO_PLUGIN_PATH, so that studies created
/// or opened later in this process (each with its own loader) find it too.
void load_plugin(const std::string& path);

/// Adds the task `python` (a box; evaluation by the function varbo.minimize() is running, if any) to a registry.
void add_python_task(Registry& registry);

// Each part registers its functions on the module.
void bind_errors(py::module_& m);
void bind_registry(py::module_& m);
void bind_study(py::module_& m);
void bind_minimize(py::module_& m);
void bind_fit(py::module_& m);
void bind_algorithm(py::module_& m);

}  // namespace varbo::python
