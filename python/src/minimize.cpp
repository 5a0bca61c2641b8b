// varbo._minimize: `varbo run` in-process with a Python objective. The study's task is the component `python`
// (varbo/host_task.hpp: a box with names, or the study's `parameters:`); its evaluation calls the Python function
// with the GIL held, everything else (fits, acquisition optimization, the store) runs with the GIL released. Stop paths: Ctrl-C (seen by
// PyErr_CheckSignals before each trial and between trials) stops like SIGINT stops `varbo run`: the trial in
// flight is abandoned, every recorded trial stays, and KeyboardInterrupt is raised; a callback returning True ends
// the run after that trial; a callback raising ends it and re-raises.
#include <cxxabi.h>
#include <unistd.h>

#include <fmt/format.h>
#include <signal.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <set>

#include <yaml-cpp/yaml.h>

#include "common.hpp"
#include "varbo/config.hpp"
#include "varbo/errors.hpp"
#include "varbo/log.hpp"
#include "varbo/host_task.hpp"
#include "varbo/interrupt.hpp"
#include "varbo/loader.hpp"
#include "varbo/store.hpp"
#include "varbo/study.hpp"
#include "varbo/text.hpp"

namespace varbo::python {

namespace {

/// What the running minimize() shares with its task (one per call; the task finds it through a thread-local).
struct Objective {
  Objective(py::object f, py::object cb) : fun(std::move(f)), callback(std::move(cb)) {}
  const pid_t owner = ::getpid();  ///< the process running minimize(); a forked child of `fun` is not it
  py::object fun;
  py::object callback;
  int stop = 0;                                  ///< sticky: once set, every later poll stops
  bool said_traceback = false;                   ///< the first failing exception's traceback is logged whole
  std::unique_ptr<py::error_already_set> error;  ///< raised again once the run has ended

  /// Called with the GIL held: Ctrl-C pending? Records the KeyboardInterrupt (or what a signal handler raised).
  bool check_signals() {
    if (stop) return true;
    if (PyErr_CheckSignals() == 0) return false;
    error = std::make_unique<py::error_already_set>();
    stop = SIGINT;
    return true;
  }
};

thread_local Objective* t_objective = nullptr;

struct ScopedObjective {
  explicit ScopedObjective(Objective* o) : previous(t_objective) { t_objective = o; }
  ~ScopedObjective() { t_objective = previous; }
  Objective* previous;
};

std::string describe(const py::error_already_set& e) {
  std::string type = "Exception";
  try {
    type = py::cast<std::string>(e.type().attr("__name__"));
  } catch (...) {
  }
  // The message as UTF-8 whatever it holds: a message with an undecodable byte (os.fsdecode(b"\xff")) failed to
  // convert, and the trial's reason became pybind11's "Unable to cast Python instance" (red team, session 23).
  std::string message;
  if (e.value()) {
    try {
      message = py::cast<std::string>(py::str(e.value()).attr("encode")("utf-8", "backslashreplace"));
    } catch (...) {
      message = "(the exception's message could not be read)";
    }
  }
  // Where it was raised: the innermost frame of its traceback. A typo in the objective (NameError) failed ten trials
  // and stopped the run with "NameError: name 'x' is not defined", no file or line (red team, session 46).
  std::string where;
  try {
    py::object tb = e.trace();
    if (!tb.is_none()) {
      while (!tb.attr("tb_next").is_none()) tb = tb.attr("tb_next");
      const py::object code = tb.attr("tb_frame").attr("f_code");
      where = fmt::format(" (at {}:{} in {})", py::cast<std::string>(py::str(code.attr("co_filename"))),
                          py::cast<long>(tb.attr("tb_lineno")), py::cast<std::string>(py::str(code.attr("co_name"))));
    }
  } catch (...) {
  }
  return fmt::format("{}: {}{}", type, message, where);
}

/// The whole traceback, as Python prints it ("" if it cannot be formatted).
std::string traceback_text(const py::error_already_set& e) {
  try {
    const py::object lines = py::module_::import("traceback").attr("format_exception")(e.type(), e.value(), e.trace());
    return py::cast<std::string>(py::str("").attr("join")(lines));
  } catch (...) {
    return {};
  }
}

/// A failed trial saying why.
Evaluation failed(std::string why) {
  Evaluation ev;
  ev.ok = false;
  ev.cost = std::nan("");
  ev.error = std::move(why);
  return ev;
}

double number(const py::handle& h) {
  // None and bool are not costs: a forgotten `return` or a `return ok` is a failed trial that says so (red-team
  // pass py11), not a NaN with no reason or a silent cost of 0/1.
  if (h.is_none())
    throw InputError("the objective returned None (a missing return?); expected a number or a dict with 'cost'");
  if (py::isinstance<py::bool_>(h) || py::isinstance(h, py::module_::import("numpy").attr("bool_")))
    throw InputError(fmt::format("the objective returned {} (type bool); expected a number or a dict with 'cost'",
                                 py::cast<std::string>(py::repr(h))));
  try {
    return py::cast<double>(h);
  } catch (const py::cast_error&) {
    throw InputError(fmt::format("the objective returned {} (type {}); expected a number or a dict with 'cost'",
                                 py::cast<std::string>(py::repr(h)),
                                 py::cast<std::string>(h.get_type().attr("__name__"))));
  }
}

/// A number, or a dict {cost: number, components: {name: number}}. NaN or ±inf: a failed trial (the runner).
void read_result(const py::object& r, Evaluation& ev) {
  if (py::isinstance<py::dict>(r)) {
    py::dict d = py::reinterpret_borrow<py::dict>(r);
    // A key the result has no use for (a misspelled 'Cost' or 'component') was dropped without a word (red team,
    // session 24): said once per key and process. Not an error: a dict may carry a caller's own extra values.
    static std::set<std::string> said;
    for (const auto& [k, v] : d) {
      const std::string key = py::isinstance<py::str>(k) ? py::cast<std::string>(k) : std::string(py::repr(k));
      if (key == "cost" || key == "components" || key == "ok" || key == "reason" || !said.insert(key).second)
        continue;
      const std::string near = closest_match(key, {"cost", "components"});
      log_warn("the objective's result has the key '{}', which is not used (a result is 'cost' and optionally "
               "'components'; 'ok': False with a 'reason' reports a failure){}",
               key, near.empty() ? "" : fmt::format("; did you mean '{}'?", near));
    }
    // {"cost": 1e9, "ok": False} was recorded as a success with cost 1e9 (red team, session 31): a failed trial,
    // as the external task's answer `"ok": false` and trials.csv's column say.
    if (d.contains("ok")) {
      const py::object ok = d["ok"];
      if (!py::isinstance<py::bool_>(ok) && !py::isinstance(ok, py::module_::import("numpy").attr("bool_")))
        throw InputError(fmt::format("the objective returned 'ok': {}; expected True or False",
                                     py::cast<std::string>(py::repr(ok))));
      if (!py::cast<bool>(ok)) {
        std::string why = "the objective returned 'ok': False";
        if (d.contains("reason") && py::isinstance<py::str>(d["reason"]))
          why += ": " + py::cast<std::string>(
                            py::str(d["reason"]).attr("encode")("utf-8", "backslashreplace").attr("decode")("utf-8"));
        throw InputError(why);
      }
    }
    if (!d.contains("cost")) throw InputError("the objective returned a dict without 'cost'");
    ev.cost = number(d["cost"]);
    if (d.contains("components")) ev.components = components_of(d["components"]);
    // As tell() refuses them: a component that is not a finite number fails the trial, saying which (a NaN was
    // stored in a complete trial).
    for (const auto& [name, v] : ev.components)
      if (!std::isfinite(v))
        throw InputError(fmt::format("the objective returned component '{}' = {}; expected a finite number", name, v));
    return;
  }
  ev.cost = number(r);
}

/// A child forked inside `fun` ("fork to sandbox the simulator") that returns or raises instead of calling
/// os._exit came back here and carried on the parent's run: it recorded its own results, abandoned the parent's
/// trial and removed its run lock (red team, session 30). The child ends here, as its code would have ended on
/// its own: SystemExit's code, else 1 after the traceback of what it raised, else 0.
void leave_if_forked(const Objective& objective, py::error_already_set* raised) {
  if (::getpid() == objective.owner) return;
  int code = 0;
  if (raised && raised->matches(PyExc_SystemExit)) {
    py::object c = raised->value().attr("code");
    if (py::isinstance<py::int_>(c)) {
      const long v = PyLong_AsLong(c.ptr());
      if (PyErr_Occurred()) PyErr_Clear();
      code = static_cast<int>(v & 0xff);
    } else if (!c.is_none()) {
      code = 1;
    }
  } else if (raised) {
    raised->restore();
    PyErr_Print();
    code = 1;
  }
  PySys_WriteStderr("varbo: a process forked inside the objective of minimize() %s; it ends here (exit %d), "
                    "not in the parent's run: end such a child with os._exit()\n",
                    raised ? "raised out of it" : "returned from it", code);
  try {
    py::module_::import("sys").attr("stdout").attr("flush")();
    py::module_::import("sys").attr("stderr").attr("flush")();
  } catch (...) {
  }
  ::_exit(code);
}

/// The evaluation of the task `python` (varbo/host_task.hpp) inside minimize(): the function called with the GIL
/// held on the params (typed with `parameters:`).
Evaluation evaluate(Objective* objective, const Vec& theta, const std::vector<std::string>& names,
                    const SearchSpace* space) {
  TakenGil gil;
  // Stopped (Ctrl-C, a KeyboardInterrupt or SystemExit from the objective): no result of θ, said by throwing
  // Interrupted (task.hpp), so that the run abandons the trial rather than recording it failed.
  if (objective->check_signals()) throw Interrupted(objective->stop ? objective->stop : SIGINT);
  Evaluation ev;
  const py::dict params = params_of(theta, names, space);
  try {
    // The C API's call, not pybind11's: a forced unwind (below) meets no C++ temporary holding a reference on its
    // way out of the call (their destructors, run without the GIL at exit, crashed the process).
    PyObject* raw = PyObject_CallOneArg(objective->fun.ptr(), params.ptr());
    if (!raw) throw py::error_already_set();
    py::object r = py::reinterpret_steal<py::object>(raw);
    leave_if_forked(*objective, nullptr);
    read_result(r, ev);
  } catch (const abi::__forced_unwind&) {
    // The program ended while the objective ran (a daemon thread): CPython ends a thread that takes the GIL back
    // then with pthread_exit. Unwinding on would release a GIL this thread does not hold (~TakenGil) and abort the
    // process; it waits here instead until the process is gone (red team, session 46).
    ReleasedGil::park();
  } catch (py::error_already_set& e) {
    leave_if_forked(*objective, &e);
    // Not an Exception (KeyboardInterrupt, SystemExit, GeneratorExit, asyncio.CancelledError, a user's
    // `class EStop(BaseException)` written so that `except Exception` cannot swallow it): the run stops and it is
    // raised again, as Python's own code would let it through. Before session 46 only the first two stopped the run;
    // the others were failed trials and the run went on (red team).
    if (!e.matches(PyExc_Exception)) {
      objective->stop = SIGINT;
      objective->error = std::make_unique<py::error_already_set>(std::move(e));
      throw Interrupted(SIGINT);
    }
    if (!objective->said_traceback) {
      objective->said_traceback = true;
      if (const std::string tb = traceback_text(e); !tb.empty())
        log_warn("minimize: the objective raised (the first such trial; later ones give the innermost line only):\n{}",
                 abbreviate(tb, 8000));
    }
    return failed(describe(e));
  } catch (const std::exception& e) {
    return failed(e.what());
  }
  return ev;
}

}  // namespace

void add_python_task(Registry& registry) {
  // Outside minimize() (varbo.Study.open on a study minimize wrote) the task gives the domain only.
  add_host_python_task(registry, [] {
    Objective* o = t_objective;
    return o ? HostEvaluator([o](const Vec& theta, const std::vector<std::string>& names, const SearchSpace* space) {
      return evaluate(o, theta, names, space);
    })
             : HostEvaluator();
  });
}

namespace {

py::dict summary_dict(const RunSummary& s) {
  py::dict d;
  d["output"] = s.output;
  d["evaluations"] = s.evaluations;
  d["failed"] = s.failed;
  d["best_x"] = s.best_theta ? py::object(to_array(*s.best_theta)) : py::object(py::none());
  d["best_cost"] = s.best_theta ? py::object(py::float_(s.best_cost)) : py::object(py::none());
  d["recommended_x"] = s.recommended_theta ? py::object(to_array(*s.recommended_theta)) : py::object(py::none());
  d["recommendation_rule"] = s.recommendation_rule;
  d["seconds"] = s.seconds;
  return d;
}

}  // namespace

void bind_minimize(py::module_& m) {
  m.def(
      "_minimize",
      [](py::object fun, const std::string& yaml, const std::string& name, py::object callback,
         std::optional<std::uint64_t> seed, std::optional<Index> budget, std::optional<int> threads,
         std::optional<std::string> output, bool resume, bool overwrite, bool progress) {
        Objective objective{std::move(fun), std::move(callback)};
        RunOverrides ov;
        ov.seed = seed;
        ov.budget = budget;
        ov.threads = threads;
        ov.output = output;
        ov.resume = resume;
        ov.overwrite = overwrite;
        ov.progress = progress;
        // The CLI cannot run a Python objective (task `python`): messages name minimize's own arguments.
        ov.resume_hint = "varbo.minimize(..., output='{}', resume=True)";
        ov.overwrite_hint = "pass overwrite=True";
        ov.stop_signal = [&objective] {
          TakenGil gil;
          objective.check_signals();
          return objective.stop;
        };
        std::vector<std::string> names;
        SharedSpace space;  // typed parameters, or null
        ov.on_trial = [&objective, &names, &space](const TrialRecord& t) {
          TakenGil gil;
          if (objective.callback.is_none()) return true;
          try {
            const py::dict record = trial_dict(t, names, space.get());
            PyObject* raw = PyObject_CallOneArg(objective.callback.ptr(), record.ptr());  // as in evaluate()
            if (!raw) throw py::error_already_set();
            const py::object answer = py::reinterpret_steal<py::object>(raw);
            if (!py::cast<bool>(py::bool_(answer))) return true;
            // Said: any truthy value ends the run ("no", a dict), and the result did not say why it stopped (red
            // team, session 46).
            // A warning unless it is True itself: `return "no"` or a dict is most likely not meant as "stop".
            const std::string text = fmt::format("minimize: the callback returned {} after trial {}: the run stops "
                                                 "here (return None or False to go on)",
                                                 safe_text(py::cast<std::string>(py::repr(answer)), 80), t.id);
            if (answer.is(py::bool_(true))) log_info("{}", text);
            else log_warn("{}", text);
            return false;
          } catch (const abi::__forced_unwind&) {  // the program ended during the callback: as in evaluate()
            ReleasedGil::park();
          } catch (py::error_already_set& e) {
            objective.error = std::make_unique<py::error_already_set>(std::move(e));
            return false;
          }
        };
        std::optional<RunSummary> summary;
        std::string given_output;  // the run folder as the caller named it (relative paths stay relative)
        {
          ReleasedGil release;
          ScopedObjective scope(&objective);
          // A registry per run, as `varbo run` builds one: the default plugins, the config's plugin_path and the
          // task `python`.
          const ConfigNode root = ConfigNode::parse(yaml, name);
          // Resuming: a seed or budget the call does not give (neither argument nor config key) is the study's,
          // as `varbo run --resume` takes the stored configuration. Before, the defaults applied: a study made with
          // seed=5 was refused as "another configuration" and a 6-trial run silently grew to 30 (red team,
          // session 23).
          if (ov.resume) {
            const std::string folder = ov.output ? *ov.output : (root.has("output") ? root.child("output").scalar() : "");
            const std::string store_path = folder + "/study.db";
            if (!folder.empty() && !is_database_url(folder) && store_exists(store_path)) {
              if (const auto stored = open_store(store_path)->meta(store_key::kConfig)) {
                const YAML::Node cfg = YAML::Load(*stored);
                if (!ov.seed && !root.has("seed") && cfg["seed"]) ov.seed = cfg["seed"].as<std::uint64_t>();
                if (!ov.budget && !root.has("budget") && cfg["budget"]) ov.budget = cfg["budget"].as<Index>();
              }
            }
          }
          Registry registry;
          PluginLoader loader(registry);
          loader.load_default(plugin_paths_of(root));
          add_python_task(registry);
          const StudyConfig study = parse_study(root, registry);
          if (study.task.info->plugin != "python")
            study.task.source.fail(fmt::format(
                "minimize() optimizes the Python function: leave the task out (give the space) or make it {{type: "
                "python, lower: [...], upper: [...]}}, not the task '{}'",
                study.task.info->name));
          {
            // The names (and typed space) the callback's trials are shown with, as the study resolves them.
            BuildContext ctx;
            const auto task = registry.create<Task>(study.task, ctx);
            Domain domain;
            space = resolve_study_space(study, *task, domain);
            names = domain.names;
          }
          // The objective may change the working directory (os.chdir): the run folder is the one meant when
          // minimize was called. Before, a relative output was looked for again after the last trial, from the new
          // directory ("run1/study.db: no such study file"), and the result and summary.json were lost.
          given_output = ov.output ? *ov.output : study.output;
          if (!is_database_url(given_output)) ov.output = std::filesystem::absolute(given_output).string();
          try {
            summary = run_study(study, registry, ov);
          } catch (const Interrupted&) {
            if (!objective.error) throw;  // a real signal to this process (not Python's handler)
          }
        }
        if (objective.error) {
          objective.error->restore();
          objective.error.reset();
          throw py::error_already_set();
        }
        py::dict out = summary_dict(*summary);
        out["output"] = given_output;
        auto typed = [&](const std::optional<Vec>& x) {
          return x ? py::object(params_of(*x, names, space.get())) : py::object(py::none());
        };
        out["best_params"] = typed(summary->best_theta);
        out["recommended_params"] = typed(summary->recommended_theta);
        out["parameters"] = space ? py::object(parameters_of(*space)) : py::object(py::none());
        std::vector<TrialRecord> trials;
        {
          ReleasedGil release;
          trials = open_sqlite_store(summary->output + "/study.db")->trials();
        }
        py::list ts;
        for (const auto& t : trials) ts.append(trial_dict(t, names, space.get()));
        out["trials"] = ts;
        out["names"] = names;
        return out;
      },
      py::arg("fun"), py::arg("yaml"), py::arg("name"), py::arg("callback"), py::arg("seed"), py::arg("budget"),
      py::arg("threads"), py::arg("output"), py::arg("resume"), py::arg("overwrite"), py::arg("progress"));
}

}  // namespace varbo::python
