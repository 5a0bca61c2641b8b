// varbo._Study: varbo::Study (varbo/study_api.hpp) with the GIL released around every store and model call. The
// Pythonic surface (configs as dicts, Trial objects, DataFrames) is varbo/study.py.
#include <fmt/format.h>

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <mutex>
#include <set>

#include "common.hpp"
#include "varbo/errors.hpp"
#include "varbo/study_api.hpp"

namespace varbo::python {

namespace {

/// One varbo::Study; a mutex makes concurrent calls from several Python threads on the same object safe (each
/// call releases the GIL first, then takes the mutex, so a long ask never blocks other Python threads).
class PyStudy {
 public:
  explicit PyStudy(Study s) : study_(std::make_unique<Study>(std::move(s))) {}
  // In a forked child the inherited connection is the parent's (SQLite and libpq forbid using it there): left as
  // it is, not closed.
  ~PyStudy() {
    if (::getpid() != owner_) static_cast<void>(study_.release());
  }
  PyStudy(const PyStudy&) = delete;
  PyStudy& operator=(const PyStudy&) = delete;

  template <class F>
  auto locked(F&& f) {
    // A Study opened before a fork (multiprocessing's default on Linux) used in the child: it waited for good on
    // this object's mutex or on a SQLite write lock another thread held at the fork, and recorded the child's
    // trials under the parent's worker name (red team, session 30). Refused before either lock is touched.
    if (::getpid() != owner_)
      throw InputError(fmt::format("{}: this Study was opened in process {}, not in this one (a forked child, e.g. "
                                   "multiprocessing): open the study again in the child with varbo.Study.open()",
                                   study_->store().location(), static_cast<long>(owner_)));
    ReleasedGil release;
    std::lock_guard<std::mutex> lock(mutex_);
    // The engine's own time in the latest call, without the Python layer (bench/python: the layer's overhead).
    struct Timer {
      double& out;
      std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();
      ~Timer() { out = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); }
    } timer{engine_seconds_};
    return f(*study_);
  }
  double engine_seconds() const { return engine_seconds_; }
  const std::vector<std::string>& names() const { return study_->domain().names; }
  /// The study's typed space (null: a box of reals).
  const SearchSpace* space() const { return study_->space().get(); }
  Study& study() { return *study_; }

 private:
  const pid_t owner_ = ::getpid();
  std::unique_ptr<Study> study_;
  std::mutex mutex_;
  double engine_seconds_ = 0;
};

std::unique_ptr<PyStudy> make(Study (*fn)(const std::string&, const std::string&), const std::string& a,
                              const std::string& b) {
  std::optional<Study> s;
  {
    ReleasedGil release;
    s.emplace(fn(a, b));
  }
  return std::make_unique<PyStudy>(std::move(*s));
}

py::object optional_trial(const std::optional<TrialRecord>& t, const PyStudy& s) {
  return t ? py::object(trial_dict(*t, s.names(), s.space())) : py::object(py::none());
}

}  // namespace

void bind_study(py::module_& m) {
  py::class_<PyStudy>(m, "_Study", "varbo::Study; use varbo.Study.")
      .def_static(
          "create_from_file",
          [](const std::string& store, const std::string& file) { return make(&Study::create, store, file); },
          py::arg("store"), py::arg("config_file"))
      .def_static(
          "create_from_yaml",
          [](const std::string& store, const std::string& yaml, const std::string& name) {
            std::optional<Study> s;
            {
              ReleasedGil release;
              s.emplace(Study::create_from_yaml(store, yaml, name));
            }
            return std::make_unique<PyStudy>(std::move(*s));
          },
          py::arg("store"), py::arg("yaml"), py::arg("name"))
      .def_static(
          "open",
          [](const std::string& store) {
            std::optional<Study> s;
            {
              ReleasedGil release;
              s.emplace(Study::open(store, add_python_task));  // studies made by varbo.minimize too
            }
            return std::make_unique<PyStudy>(std::move(*s));
          },
          py::arg("store"))
      .def(
          "ask",
          [](PyStudy& s, Index n) {
            std::vector<TrialRecord> asked = s.locked([&](Study& st) { return st.ask(n); });
            // Ctrl-C (or a signal handler that raises) during the ask: Python raised it right after this returned,
            // and the trials just asked stayed pending, held the budget and were never handed to anyone (red team,
            // session 30). They are abandoned here, then the exception is raised.
            if (!asked.empty() && PyErr_CheckSignals() != 0) {
              py::error_already_set raised;
              std::set<std::int64_t> ids;
              for (const auto& t : asked) ids.insert(t.id);
              try {
                s.locked([&](Study& st) {
                  st.abandon_where([&](const TrialRecord& t) { return ids.count(t.id) > 0; },
                                   "interrupted while asking (the trial was never handed out)");
                });
              } catch (const std::exception&) {
                // The interrupt is what the user is told; a pending trial left is abandoned later by `varbo abandon`.
              }
              throw raised;
            }
            py::list out;
            for (const auto& t : asked) out.append(trial_dict(t, s.names(), s.space()));
            return out;
          },
          py::arg("n") = 1)
      .def(
          "tell",
          [](PyStudy& s, std::int64_t id, double cost, const py::object& components) {
            const Components c = components_of(components);
            s.locked([&](Study& st) { st.tell(id, cost, c); });
          },
          py::arg("id"), py::arg("cost"), py::arg("components") = py::none())
      .def(
          "tell_point",
          [](PyStudy& s, const py::object& theta, double cost, const py::object& components) {
            const Vec v = to_vec(theta, "tell_point: θ");
            const Components c = components_of(components);
            return s.locked([&](Study& st) { return st.tell_point(v, cost, c); });
          },
          py::arg("theta"), py::arg("cost"), py::arg("components") = py::none())
      .def(
          "tell_params",
          [](PyStudy& s, const py::object& params, double cost, const py::object& components) {
            const Domain& dom = s.study().domain();
            const Vec v = theta_of_mapping(params, s.space(), dom.box, dom.names, "tell_point");
            const Components c = components_of(components);
            return s.locked([&](Study& st) { return st.tell_point(v, cost, c); });
          },
          py::arg("params"), py::arg("cost"), py::arg("components") = py::none())
      .def(
          "fail_point",
          [](PyStudy& s, const py::object& theta, const std::string& reason) {
            const Vec v = to_vec(theta, "fail_point: θ");
            return s.locked([&](Study& st) { return st.fail_point(v, reason); });
          },
          py::arg("theta"), py::arg("reason") = "failed")
      .def(
          "fail_params",
          [](PyStudy& s, const py::object& params, const std::string& reason) {
            const Domain& dom = s.study().domain();
            const Vec v = theta_of_mapping(params, s.space(), dom.box, dom.names, "fail_point");
            return s.locked([&](Study& st) { return st.fail_point(v, reason); });
          },
          py::arg("params"), py::arg("reason") = "failed")
      .def(
          "fail",
          [](PyStudy& s, std::int64_t id, const std::string& reason) {
            s.locked([&](Study& st) { st.fail(id, reason); });
          },
          py::arg("id"), py::arg("reason") = "failed")
      .def(
          "created_at",
          [](PyStudy& s, std::int64_t id) -> py::object {
            const std::optional<TrialRecord> t = s.locked([&](Study& st) { return st.store().trial(id); });
            return t ? py::object(py::float_(t->created_at)) : py::object(py::none());
          },
          py::arg("id"), "when trial `id` of this study was made (None: no such trial)")
      .def(
          "retract_failures",
          [](PyStudy& s, const std::vector<std::int64_t>& ids, const std::string& reason) {
            return s.locked([&](Study& st) { return st.retract_failures(ids, reason); });
          },
          py::arg("ids"), py::arg("reason"))
      .def(
          "abandon",
          [](PyStudy& s, double older_than) {
            return s.locked([&](Study& st) { return st.abandon(older_than, "abandoned from Python"); });
          },
          py::arg("older_than") = 0.0)
      .def("best",
           [](PyStudy& s) {
             auto b = s.locked([](Study& st) { return st.best(); });
             return optional_trial(b, s);
           })
      .def("recommendation",
           [](PyStudy& s) -> py::object {
             auto theta = s.locked([](Study& st) { return st.recommendation(); });
             if (!theta) return py::none();
             py::dict d;
             d["x"] = to_array(*theta);
             d["params"] = params_of(*theta, s.names(), s.space());
             return d;
           })
      .def("trials",
           [](PyStudy& s) {
             auto ts = s.locked([](Study& st) { return st.trials(); });
             py::list out;
             for (const auto& t : ts) out.append(trial_dict(t, s.names(), s.space()));
             return out;
           })
      .def(
          "select",
          [](PyStudy& s, const std::vector<double>& kappas) -> py::list {
            // A NaN κ reached the selection's arithmetic as a std::bad_alloc (red-team pass py11).
            for (const double kappa : kappas)
              if (!std::isfinite(kappa))
                throw InputError(fmt::format("select: kappa must be a finite number, got {}", kappa));
            // One fit for every κ (it was one per κ, and varbo.Study.select called this once per κ).
            const auto sels = s.locked([&](Study& st) { return st.select(kappas); });
            py::list out;
            for (std::size_t k = 0; k < sels.size(); ++k) {
              const auto& sel = sels[k];
              if (!sel) {
                out.append(py::none());
                continue;
              }
              py::dict d;
              d["kappa"] = kappas[k];
              d["trial_id"] = sel->trial_id;
              d["x"] = to_array(sel->theta);
              d["params"] = params_of(sel->theta, s.names(), s.space());
              d["mean"] = sel->mean;
              d["std"] = sel->std;
              d["value"] = sel->value;
              out.append(d);
            }
            return out;
          },
          py::arg("kappas"))
      .def("heartbeat", [](PyStudy& s, const std::string& state) { s.locked([&](Study& st) { st.heartbeat(state); }); },
           py::arg("state") = "running")
      .def("set_worker", [](PyStudy& s, const std::string& name) { s.locked([&](Study& st) { st.set_worker(name); }); })
      .def_property_readonly("engine_seconds", &PyStudy::engine_seconds,
                             "seconds the C++ engine spent in the latest call (the rest is the Python layer)")
      .def_property_readonly("names", [](PyStudy& s) { return s.names(); })
      .def_property_readonly("parameters",
                             [](PyStudy& s) -> py::object {
                               return s.space() ? py::object(parameters_of(*s.space())) : py::object(py::none());
                             })
      .def_property_readonly("lower", [](PyStudy& s) { return to_array(s.study().domain().box.lower); })
      .def_property_readonly("upper", [](PyStudy& s) { return to_array(s.study().domain().box.upper); })
      .def_property_readonly("budget", [](PyStudy& s) { return s.study().config().budget; })
      .def_property_readonly("seed", [](PyStudy& s) { return s.study().config().seed; })
      .def_property_readonly("location", [](PyStudy& s) { return s.study().store().location(); })
      .def_property_readonly("config", [](PyStudy& s) {
        YAML::Emitter em;
        em << s.study().config().resolved();
        return std::string(em.c_str());
      });
}

}  // namespace varbo::python
