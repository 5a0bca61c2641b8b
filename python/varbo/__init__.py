"""varbo — risk-aware and cautious Bayesian optimization (C++ engine) from Python.

    import varbo
    res = varbo.minimize(lambda p: (p["x"] - 1) ** 2 + p["y"] ** 2, {"x": (-5, 5), "y": (-5, 5)}, budget=30)
    res.x, res.fun, res.recommended_params

Studies (durable ask/tell, shared by processes and with the ``varbo`` CLI): ``Study.create`` / ``Study.open``.
Models: ``fit`` (the numbers of ``varbo fit``). Components: ``plugins``, ``describe``, ``load_plugin``.
Optuna users: ``varbo.optuna.VarboSampler``. Reference: docs/python.md.
"""
from __future__ import annotations

import math
import os
import tempfile
from typing import Any, Callable, Dict, Iterable, List, Mapping, Optional, Sequence, Union

import numpy as np

from . import _varbo
from . import _checks
from ._config import has_parameters, has_task, is_path, to_yaml
from ._types import OptimizeResult, ParamValue, Prediction, Selection, Trial, trial_from
from ._varbo import (ConfigError, Error, InputError, NumericalError, PluginLoadError, UnknownComponentError,
                     skipped_plugins)


def _str_arg(v: Any, what: str, optional: bool = False) -> Any:
    if (optional and v is None) or isinstance(v, str):
        return v
    raise TypeError(f"{what}: expected a str{' or None' if optional else ''}, got {v!r:.60} (type {type(v).__name__})")


def plugins(kind: Optional[str] = None) -> List[Dict[str, Any]]:
    """The loaded components (dicts: name, full_name, kind, plugin, library, builtin, description, provides, needs),
    all or those of one kind ("task", "algorithm", "surrogate", ...)."""
    return _varbo.plugins(_str_arg(kind, "plugins: kind", optional=True))


def describe(name: str) -> Dict[str, Any]:
    """A component's description with its options; ``describe("study")`` the study file's top-level keys."""
    return _varbo.describe(_str_arg(name, "describe: name"))


def load_plugin(path: Union[str, "os.PathLike[str]"]) -> None:
    """Loads a third-party ``libvarbo_NAME.so`` into the process (and appends it to ``VARBO_PLUGIN_PATH``)."""
    _varbo.load_plugin(_checks.path(path, "load_plugin: path"))


def set_log_level(level: str) -> None:
    """debug, info, warn, error or quiet (the engine's messages on stderr)."""
    _varbo.set_log_level(_str_arg(level, "set_log_level: level"))


__version__ = _varbo.__version__
# Quiet by default, as Python's logging is: warnings and errors on stderr; a run folder's log.txt still gets every
# info line. varbo.set_log_level("info") shows the engine's progress messages as the CLI does.
set_log_level("warn")
__all__ = [
    "Study", "Trial", "Selection", "Model", "Prediction", "OptimizeResult", "minimize", "fit", "plugins",
    "describe", "load_plugin", "skipped_plugins", "set_log_level", "Error", "ConfigError",
    "UnknownComponentError", "InputError", "PluginLoadError", "NumericalError",
]

Config = Union[Mapping[str, Any], str, "os.PathLike[str]"]


def _same_store(a: str, b: str) -> bool:
    """Two locations of one store: equal, or one file by two paths (relative/absolute, a symlink)."""
    if a == b:
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # a URL, or a file deleted meanwhile
        return False


def _trial_id(trial_or_id: Union[Trial, int], study: Optional["Study"] = None) -> int:
    if isinstance(trial_or_id, Trial):
        # A Trial asked from another study has an id this study may hold too: telling it here would record the
        # result on the wrong trial, silently (red-team pass py11). Trials remember the store they came from.
        origin = getattr(trial_or_id, "_store", None)
        if study is not None and origin is not None and not _same_store(origin, study._origin):
            raise InputError(f"trial {trial_or_id.id} belongs to the study {origin}, not to {study._location}; "
                             "tell each study its own trials")
        # The same path, another study: the file was deleted and created again (a notebook re-run), and the old
        # Trial's result was recorded on the new study's trial of that id, another θ (red team, session 30).
        if study is not None and trial_or_id.created_at:
            made = study._impl.created_at(trial_or_id.id)
            if made is not None and abs(made - trial_or_id.created_at) > 1e-6:
                raise InputError(f"trial {trial_or_id.id} of {study._location} is not the trial you hold (made at "
                                 f"another time: the study file was created again since?); nothing written")
        return trial_or_id.id
    if isinstance(trial_or_id, (int, np.integer)) and not isinstance(trial_or_id, (bool, np.bool_)):
        i = int(trial_or_id)
        if not -2 ** 63 <= i < 2 ** 63:  # no trial has it (the C++ id is int64)
            raise InputError(f"unknown trial id {i}: no trial of this study has it")
        return i
    raise TypeError(f"expected a Trial or a trial id (int), got {type(trial_or_id).__name__}")


def _reason(reason: Any, where: str) -> str:
    if reason is None:
        return "failed"  # not the text "None"
    if not isinstance(reason, str):
        raise TypeError(f"{where}: reason: expected a str, got {type(reason).__name__}")
    # A reason that is not valid UTF-8 (os.fsdecode of a device name) is kept with escapes; it raised
    # pybind11's "incompatible function arguments" (red team, session 23).
    return reason.encode("utf-8", "backslashreplace").decode("utf-8")


def _components(components: Any) -> Optional[Dict[str, Any]]:
    if components is None:
        return None
    if not isinstance(components, Mapping):
        raise TypeError(f"components: expected a dict {{name: number}}, got {type(components).__name__}")
    return dict(components)


def _cost_and_components(cost: Any, components: Optional[Mapping[str, float]]):
    if isinstance(cost, Mapping):
        unused = [k for k in cost if k not in ("cost", "components", "ok", "reason")]
        if unused:  # a misspelled 'Cost' or 'component' was dropped without a word (red team, session 24)
            import warnings
            warnings.warn(f"the result dict's key(s) {', '.join(repr(k) for k in unused)} are not used (a result is "
                          f"'cost' and optionally 'components')", UserWarning, stacklevel=3)
        if "cost" not in cost:
            raise InputError("a result dict needs 'cost' (and optionally 'components')")
        if components is not None and cost.get("components") is not None:
            # Both given: the keyword's won in silence (red team, session 46).
            raise InputError("components given twice: in the result dict and as components=; give them once")
        comps = cost.get("components") if components is None else components
        return _checks.real(cost["cost"], "cost"), _components(comps)
    return _checks.real(cost, "cost"), _components(components)


class Study:
    """A durable ask/tell study (``varbo::Study``): a SQLite file holding the configuration, every trial and the
    algorithm's state. Several processes (and the ``varbo`` CLI: ``varbo status/suggest/observe``) may share it;
    every call commits to the store, so a crash loses nothing that was told.

    Methods release the GIL while the engine works; one Study may be used from several threads (calls are
    serialized), and different studies run in parallel.
    """

    def __init__(self, impl: "_varbo._Study") -> None:
        if not isinstance(impl, _varbo._Study):
            raise TypeError("varbo.Study is made by Study.create(path, config) or Study.open(path), not Study(...)")
        self._impl = impl
        self._location = impl.location
        # Where this study's trials come from, independent of the working directory: a trial asked here and told
        # after os.chdir must still be recognized as this study's (and another study's `s.db` as not).
        self._origin = self._location if "://" in self._location else os.path.abspath(self._location)
        # The file this object writes to (None: a URL). SQLite keeps writing to a deleted or replaced file through
        # its open descriptor, so results told after `rm study.db` would vanish silently (red-team pass py11):
        # every writing call first checks that the path still names that file (one stat, ~µs).
        self._file: Optional[tuple] = None
        if "://" not in self._location:
            try:
                st = os.stat(self._location)
                self._file = (os.path.abspath(self._location), st.st_dev, st.st_ino)
            except OSError:
                pass

    def _check_file(self) -> None:
        if self._file is None:
            return
        path, dev, ino = self._file
        try:
            st = os.stat(path)
            if (st.st_dev, st.st_ino) == (dev, ino):
                return
            what = "replaced by another file"
        except OSError:
            what = "deleted or moved"
        raise InputError(f"{path}: the study file was {what} after this Study opened it; nothing written (results "
                         "told now would be lost): open the study again with varbo.Study.open")

    def _trial(self, d: Dict[str, Any]) -> Trial:
        t = trial_from(d)
        t._store = self._origin  # not a dataclass field: equality and repr stay as they were
        return t

    def __copy__(self) -> "Study":
        return Study(self._impl)  # the same connection (calls stay serialized)

    def __reduce__(self):
        # A Study is a live connection to its store (and the algorithm's state): reopen it by its location.
        raise TypeError(f"cannot pickle or deepcopy a varbo.Study; pickle its location and reopen it with "
                        f"varbo.Study.open({self.location!r})")

    @classmethod
    def create(cls, path_or_url: Union[str, "os.PathLike[str]"], config: Config) -> "Study":
        """Creates a new study at ``path_or_url`` from a study configuration (a dict, YAML text or a YAML file: the
        file ``varbo run`` takes: task, algorithm, budget, seed, ...). An existing file is an InputError; a bad
        configuration a ConfigError naming file:line:col and the key."""
        location = _checks.path(path_or_url, "Study.create: path_or_url")
        if is_path(config):
            file = _checks.path(config, "Study.create: config")
            try:
                with open(file, encoding="utf-8") as f:
                    text = f.read()
            except (OSError, UnicodeDecodeError):
                text = ""  # the C++ reader says what is wrong with the file (a ConfigError naming it)
            if not (has_parameters(text) and not has_task(text)):
                return cls(_varbo._Study.create_from_file(location, file))
            # Typed parameters alone, as for a dict or a text (minimize took such a file, create refused it:
            # "key 'task': missing required key"; red team, session 31). Appended: the file's lines keep their numbers.
            return cls(_varbo._Study.create_from_yaml(location, text.rstrip("\n") + "\ntask: {type: python}\n", file))
        if isinstance(config, Mapping) and "parameters" in config and "task" not in config:
            # Typed parameters alone: the task `python` takes them as the domain, evaluated by the caller (ask/tell).
            config = dict(config, task={"type": "python"})
        text, name = to_yaml(config)
        if not isinstance(config, Mapping) and has_parameters(text) and not has_task(text):
            text = text.rstrip("\n") + "\ntask: {type: python}\n"
        return cls(_varbo._Study.create_from_yaml(location, text, name))

    @classmethod
    def open(cls, path_or_url: Union[str, "os.PathLike[str]"]) -> "Study":
        """Opens an existing study (the algorithm is restored from its saved state)."""
        return cls(_varbo._Study.open(_checks.path(path_or_url, "Study.open: path_or_url")))

    def ask(self, n: int = 1) -> List[Trial]:
        """Up to ``n`` new pending trials (fewer, possibly none, once the budget is spent)."""
        n = _checks.integer(n, "ask: n", 1)
        self._check_file()
        return [self._trial(d) for d in self._impl.ask(n)]

    def tell(self, trial_or_id: Union[Trial, int], cost: Union[float, Mapping[str, Any]],
             components: Optional[Mapping[str, float]] = None) -> None:
        """Records the result of a pending trial: a finite cost (or ``{"cost": c, "components": {...}}``).
        A NaN or infinite cost is an InputError: report a trial that could not be measured with ``fail``. A dict with
        ``"ok": False`` (and optionally ``"reason"``) is recorded as ``fail`` would."""
        if isinstance(cost, Mapping) and "ok" in cost:
            ok = cost["ok"]
            if not isinstance(ok, (bool, np.bool_)):
                raise TypeError(f"tell: 'ok': expected True or False, got {ok!r:.40}")
            if not ok:  # was recorded as a success (red team, session 31)
                self.fail(trial_or_id, _reason(cost.get("reason"), "tell") if cost.get("reason") is not None
                          else "the result says 'ok': False")
                return
        c, comps = _cost_and_components(cost, components)
        i = _trial_id(trial_or_id, self)
        self._check_file()
        self._impl.tell(i, c, comps)

    def fail(self, trial_or_id: Union[Trial, int], reason: str = "failed") -> None:
        """Marks a pending trial failed (it counts against the budget; bo learns where trials fail)."""
        i = _trial_id(trial_or_id, self)
        reason = _reason(reason, "fail")
        self._check_file()
        self._impl.fail(i, reason)

    def fail_point(self, x: Union[Mapping[str, Any], Sequence[float], np.ndarray], reason: str = "failed") -> int:
        """Records that a point no suggestion produced failed, e.g. a hand-tried policy on which the robot fell
        (phase "manual", as ``varbo fail STUDY new``): bo's failure model learns of it as of any failed trial.
        ``x`` as for ``tell_point``; returns the trial id."""
        reason = _reason(reason, "fail_point")
        self._check_file()
        if isinstance(x, Mapping):
            return self._impl.fail_params(dict(x), reason)
        return self._impl.fail_point(_checks.float_array(x, "fail_point: x"), reason)

    def tell_point(self, x: Union[Mapping[str, Any], Sequence[float], np.ndarray], cost: float,
                   components: Optional[Mapping[str, float]] = None) -> int:
        """Records the cost of a point no suggestion produced (phase "manual"); returns its trial id.

        ``x``: ``{name: value}`` in your units — numbers for real and int parameters, labels (str) for categorical
        ones; a fixed parameter may be left out — parsed exactly as ``varbo observe new --param name=value``; or
        θ as an array (a category by its index). An unknown, missing or inadmissible value is an InputError (a
        ValueError) naming the parameter, with nothing written."""
        c, comps = _checks.real(cost, "tell_point: cost"), _components(components)
        self._check_file()
        if isinstance(x, Mapping):
            return self._impl.tell_params(dict(x), c, comps)
        return self._impl.tell_point(_checks.float_array(x, "tell_point: x"), c, comps)

    def best(self) -> Optional[Trial]:
        """The complete trial with the lowest observed cost (None before the first result)."""
        d = self._impl.best()
        return None if d is None else self._trial(d)

    def recommendation(self) -> Optional[Dict[str, ParamValue]]:
        """The parameters to deploy: the algorithm's recommendation after every finished trial (bo: its
        ``recommendation`` rule on a model of all of them), as ``varbo run`` writes to summary.json; None before the
        first result or when the algorithm recommends nothing."""
        d = self._impl.recommendation()
        return None if d is None else d["params"]

    def trials(self, as_frame: Optional[bool] = None):
        """Every trial by id: a ``pandas.DataFrame`` when pandas is importable (columns ``params_<name>`` and
        ``components_<name>``, as Optuna's ``trials_dataframe``), else a list of Trial. ``as_frame`` forces either."""
        if as_frame is not None:
            as_frame = _checks.flag(as_frame, "trials: as_frame")  # "no" was taken as true
        records = [self._trial(d) for d in self._impl.trials()]
        if as_frame is False:
            return records
        try:
            import pandas as pd
        except ImportError:
            if as_frame:
                raise
            return records
        fixed = ("id", "state", "phase", "cost", "error", "worker", "created_at", "finished_at", "fit_seconds",
                 "acquisition_seconds", "evaluation_seconds")
        rows = []
        for t in records:
            row = {k: getattr(t, k) for k in fixed}
            row.update({f"params_{k}": v for k, v in t.params.items()})
            row.update({f"components_{k}": v for k, v in t.components.items()})
            rows.append(row)
        # The columns even without a row: `df[df["state"] == "complete"]` on a new study raised KeyError.
        columns = list(fixed) + [f"params_{n}" for n in self.names]
        for row in rows:
            columns += [k for k in row if k not in columns]
        return pd.DataFrame(rows, columns=columns)

    def select(self, kappas: Union[float, Iterable[float]] = 0.0):
        """Risk after learning (Kuindersma 2013, section 3.4): among complete trials, the one minimizing
        E[y] + κ·sqrt(V[y]) under the study's surrogate refitted on every result; κ > 0 is risk-averse. One
        Selection for a number, a list for a sequence of κ; None when nothing is complete."""
        if isinstance(kappas, (int, float, np.floating, np.integer)):
            d = self._impl.select([_checks.real(kappas, "select: kappa", finite=True)])[0]
            return None if d is None else Selection(**d)
        if isinstance(kappas, (str, bytes)) or not isinstance(kappas, Iterable):
            raise TypeError(f"select: kappa: expected a number or a sequence of numbers, got {type(kappas).__name__}")
        ks = [_checks.real(k, "select: kappa", finite=True) for k in kappas]
        # One model fit for the whole sweep (it was one per κ: 5.6 s each at N = 500).
        return [None if d is None else Selection(**d) for d in self._impl.select(ks)] if ks else []

    def abandon(self, older_than: float = 0.0) -> List[int]:
        """Marks pending trials abandoned (all, or those older than ``older_than`` seconds); returns their ids."""
        older_than = _checks.real(older_than, "abandon: older_than")
        self._check_file()
        return list(self._impl.abandon(older_than))

    def retract_failures(self, ids: Iterable[int], reason: str = "the rig, not θ, failed") -> List[int]:
        """Takes failed trials back (``varbo retract``): the rig failed them, not their θ. They stay failed trials in
        the study and count against its budget, but the algorithm is rebuilt without them, so bo's failure model
        forgets them (a ``bo`` study only). Other processes with the study open rebuild at their next ask. Returns the
        ids taken back."""
        if isinstance(ids, (str, bytes)) or not isinstance(ids, Iterable):
            raise TypeError(f"retract_failures: ids: expected a sequence of trial ids, got {type(ids).__name__}")
        wanted = [_checks.integer(i, "retract_failures: id") for i in ids]
        self._check_file()
        return list(self._impl.retract_failures(wanted, _checks.text(reason, "retract_failures: reason")))

    def heartbeat(self, state: str = "running") -> None:
        """A sign of life of this worker: once sent, a worker silent for longer than the study's heartbeat_timeout
        has its pending trials abandoned by the next ask of any process."""
        self._impl.heartbeat(_checks.text(state, "heartbeat: state"))

    def set_worker(self, name: str) -> None:
        """Name recorded as the worker of the trials this object asks for (default "host:pid")."""
        self._impl.set_worker(_checks.text(name, "set_worker: name"))

    @property
    def names(self) -> List[str]:
        return list(self._impl.names)

    @property
    def parameters(self) -> Optional[List[Dict[str, Any]]]:
        """The typed parameters (``parameters:`` with defaults filled in: name, type, low/high/log, choices or
        value), or None for a plain box of reals."""
        return self._impl.parameters

    @property
    def bounds(self) -> List[tuple]:
        """[(low, high)] per parameter, in your units."""
        return list(zip(self._impl.lower.tolist(), self._impl.upper.tolist()))

    @property
    def budget(self) -> int:
        return self._impl.budget

    @property
    def seed(self) -> int:
        return self._impl.seed

    @property
    def location(self) -> str:
        return self._impl.location

    @property
    def config(self) -> str:
        """The resolved configuration (YAML, every default filled in)."""
        return self._impl.config

    def __repr__(self) -> str:
        return f"varbo.Study({self.location!r}, parameters={self.names}, budget={self.budget})"


# ---- minimize ---------------------------------------------------------------------------------------------------

def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)


def _is_bounds(v: Any) -> bool:
    return isinstance(v, (tuple, list)) and len(v) == 2 and all(_is_number(b) for b in v)


def _space_task(space: Any) -> Dict[str, Any]:
    """{name: (low, high)} or [(low, high), ...] as the task `python`."""
    if isinstance(space, Mapping):
        for k in space:
            if not isinstance(k, str) or not k:
                raise ConfigError(f"space: every parameter name must be a non-empty str, got {k!r}")
        names = list(space)
        bounds = [tuple(b.tolist()) if isinstance(b, np.ndarray) and b.ndim == 1 else b for b in space.values()]
    else:
        bounds = [tuple(b) if isinstance(b, (list, tuple, np.ndarray)) else b for b in space]
        names = None
    for i, b in enumerate(bounds):
        where = names[i] if names else f"entry {i}"
        if not _is_bounds(b):
            raise ConfigError(f"space: {where}: expected (low, high), got {b!r}")
        if not (math.isfinite(float(b[0])) and math.isfinite(float(b[1]))):
            raise ConfigError(f"space: {where}: the bounds must be finite, got {b!r}")
    task = {"type": "python", "lower": [float(b[0]) for b in bounds], "upper": [float(b[1]) for b in bounds]}
    if names:
        task["names"] = names
    return task


def _is_typed_space(obj: Any) -> bool:
    """A list of parameter declarations, as the study file's ``parameters:`` ([{name, type, ...}, ...])."""
    return (isinstance(obj, (list, tuple)) and len(obj) > 0
            and all(isinstance(p, Mapping) and "name" in p for p in obj))


def _looks_like_space(obj: Any) -> bool:
    if _is_typed_space(obj):
        return True
    if isinstance(obj, Mapping):
        return len(obj) > 0 and all(_is_bounds(v) for v in obj.values())
    return isinstance(obj, (list, tuple)) and len(obj) > 0 and all(_is_bounds(b) for b in obj)


def minimize(fun: Callable[[Dict[str, Any]], Any], config_or_space: Any = None, *, space: Any = None,
             budget: Optional[int] = None, seed: Optional[int] = None,
             callback: Optional[Callable[[Trial], Any]] = None, threads: Optional[int] = None,
             output: Optional[str] = None, resume: bool = False, overwrite: bool = False,
             progress: bool = False) -> OptimizeResult:
    """Minimizes ``fun`` in this process with varbo's engine, exactly as ``varbo run`` runs a study.

    ``fun(params)`` gets a dict {name: value} (typed with ``parameters:``: int for int parameters, the label
    (str) for categorical ones, fixed values included) and returns a number or ``{"cost": c, "components": {...}}``; an
    exception, None, NaN or ±inf is a failed trial (recorded with the reason; bo learns where trials fail).
    ``config_or_space``: a search space — ``{"x": (low, high), ...}``, ``[(low, high), ...]`` or typed parameters
    ``[{"name": "lr", "type": "real", "low": 1e-5, "high": 0.1, "log": True}, ...]`` as the study file's
    ``parameters:`` — or a study configuration (dict, YAML text or file) whose ``task:`` is left out (``space=`` or
    its ``parameters:`` give the space) or is ``{type: python, lower: [...], upper: [...], names: [...]}``. Default algorithm: the plain ``{type: bo}``.
    ``callback(trial)`` runs after each recorded trial; returning True ends the run, raising ends it and re-raises.

    The GIL is released while the engine fits and optimizes (other Python threads run). Ctrl-C stops between
    trials or during ``fun``: the trial in flight is abandoned, every recorded trial stays in the run folder, and
    KeyboardInterrupt is raised; ``minimize(..., output=that_folder, resume=True)`` continues. The run folder is
    ``output``, else the config's ``output:``, else a new temporary folder.
    """
    if not callable(fun):
        raise TypeError("minimize: fun must be callable")
    if callback is not None and not callable(callback):
        raise TypeError("minimize: callback must be callable or None")
    budget = _checks.optional_integer(budget, "minimize: budget", 1)  # as the config's budget: [1, inf]
    seed = _checks.optional_integer(seed, "minimize: seed", 0, _checks.INT64_MAX)
    threads = _checks.optional_integer(threads, "minimize: threads", 0, 2 ** 31 - 1)
    if output is not None:
        output = _checks.path(output, "minimize: output")
    resume = _checks.flag(resume, "minimize: resume")
    overwrite = _checks.flag(overwrite, "minimize: overwrite")
    progress = _checks.flag(progress, "minimize: progress")
    if isinstance(config_or_space, np.ndarray):  # [[low, high], ...] as an array
        config_or_space = [tuple(r) for r in config_or_space.tolist()] if config_or_space.ndim == 2 else config_or_space
    if isinstance(space, np.ndarray):
        space = [tuple(r) for r in space.tolist()] if space.ndim == 2 else space
    if (config_or_space is not None and space is None and isinstance(config_or_space, Mapping) and config_or_space
            and not ({"task", "parameters"} & set(config_or_space))
            and all(isinstance(v, (list, tuple, np.ndarray)) for v in config_or_space.values())):
        # {name: (low, high)}; a bound of another form (an array, three numbers) is named by _space_task rather than
        # reported as "no search space" (red team, session 22)
        space, config_or_space = config_or_space, None  # {name: (low, high)} with a bad bound: _space_task says which
    if space is not None and not _is_typed_space(space):
        if isinstance(space, (str, bytes)) or not isinstance(space, (Mapping, list, tuple)):
            raise TypeError(f"minimize: space: expected {{name: (low, high)}}, [(low, high), ...] or parameter "
                            f"declarations, got {type(space).__name__}")
        if len(space) == 0:
            raise ConfigError("minimize: space: empty; give at least one (low, high)")
    if config_or_space is not None and space is None and _looks_like_space(config_or_space):
        space, config_or_space = config_or_space, None
    if config_or_space is None:
        config_or_space = {}
    if isinstance(config_or_space, Mapping):
        cfg = dict(config_or_space)
        if space is not None:
            if "task" in cfg or "parameters" in cfg:
                raise ConfigError("minimize: give the space either as space= or as the config's task or parameters, "
                                  "not both")
            if _is_typed_space(space):
                cfg["parameters"] = [dict(p) for p in space]
                cfg["task"] = {"type": "python"}
            else:
                cfg["task"] = _space_task(space)
        elif "parameters" in cfg and "task" not in cfg:
            cfg["task"] = {"type": "python"}  # the typed space of `parameters:` (docs/search_space.md)
        elif "task" not in cfg:
            raise ConfigError("minimize: no search space: pass {name: (low, high), ...} or a config with "
                              "task: {type: python, lower: [...], upper: [...]}")
        text, name = to_yaml(cfg)
        given_output = "output" in cfg
    else:
        text, name = to_yaml(config_or_space)
        import json
        if space is not None:
            if has_task(text) or has_parameters(text):
                raise ConfigError(f"{name}: give the space either as space= or as the config's task or parameters, "
                                  "not both")
            if _is_typed_space(space):
                text = (text.rstrip("\n") + "\nparameters: " + json.dumps([dict(p) for p in space], ensure_ascii=False)
                        + "\ntask: {type: python}\n")
            else:
                text = text.rstrip("\n") + "\ntask: " + json.dumps(_space_task(space), ensure_ascii=False) + "\n"
        elif has_parameters(text) and not has_task(text):
            text = text.rstrip("\n") + "\ntask: {type: python}\n"
        elif not has_task(text):
            raise ConfigError(f"{name}: no search space: pass space={{name: (low, high), ...}} or give the config "
                              "task: {type: python, lower: [...], upper: [...]}")
        given_output = _has_output(text)
    if resume and overwrite:
        raise InputError("minimize: resume=True continues the run in output, overwrite=True replaces it: give one")
    if resume and output is None and not given_output:
        raise InputError("minimize: resume=True needs the run folder to continue: output=...")
    made_folder = None
    if output is None and not given_output:
        output = made_folder = tempfile.mkdtemp(prefix="varbo-minimize-")
        overwrite = True
    user_callback = callback
    # Trials remember their study, as Study.ask's do: one told to another study with the same id was recorded
    # there silently (red team, session 23).
    store_of = (lambda folder: os.path.join(os.fspath(folder), "study.db"))

    def own(d: Dict[str, Any], folder: Any) -> Trial:
        t = trial_from(d)
        if folder is not None:
            t._store = store_of(folder)
        return t

    def on_trial(d: Dict[str, Any]) -> Any:
        return user_callback(own(d, output))

    try:
        r = _varbo._minimize(fun, text, name, None if callback is None else on_trial, seed, budget, threads,
                             None if output is None else os.fspath(output), resume, overwrite, progress)
    except BaseException:
        # A run refused before its first write (a bad config, a space it cannot use) left an empty temporary
        # folder per call: the test suite alone left hundreds in /tmp (red team, session 29). One holding a
        # study is kept: its trials are the user's.
        if made_folder is not None:
            try:
                os.rmdir(made_folder)  # only if empty
            except OSError:
                pass
        raise
    return OptimizeResult(x=r["best_x"], fun=r["best_cost"], params=r["best_params"],
                          recommended_x=r["recommended_x"], recommended_params=r["recommended_params"],
                          recommendation_rule=r["recommendation_rule"],
                          trials=[own(d, r["output"]) for d in r["trials"]], output=r["output"],
                          evaluations=r["evaluations"], failed=r["failed"], seconds=r["seconds"])


def _has_output(yaml_text: str) -> bool:
    import re
    return re.search(r"^output\s*:", yaml_text, re.MULTILINE) is not None


# ---- fit --------------------------------------------------------------------------------------------------------

class Model:
    """A surrogate fitted by ``fit``: ``predict(X)``, and the fit's ``hyperparameters``, ``objective`` (log marginal
    likelihood or bound + log hyperprior), ``objective_without_prior``, ``log_prior``, ``state`` (VHGP: log Λ, ...),
    ``ok``, ``optimized``, ``message`` — the fields of ``varbo fit``'s JSON."""

    def __init__(self, impl: "_varbo._Model") -> None:
        self._impl = impl
        info = impl.info()
        self.surrogate: str = info["surrogate"]
        self.config: str = info["config"]
        self.ok: bool = info["ok"]
        self.optimized: bool = info["optimized"]
        self.objective: float = info["objective"]
        self.objective_without_prior: float = info["objective_without_prior"]
        self.log_prior: float = info["log_prior"]
        self.message: str = info["message"]
        self.hyperparameters: Dict[str, float] = info["hyperparameters"]
        self.state: Dict[str, np.ndarray] = info["state"]
        self.dim: int = impl.dim

    def predict(self, X: Any, gradients: bool = False) -> Prediction:
        """The predictive distribution at each row of X (n × d; a 1-D X is one point)."""
        X = _checks.float_array(X, "predict: X")
        if X.ndim == 1:
            X = X.reshape(1, -1) if X.size == self.dim else X.reshape(-1, 1)
        return Prediction(**self._impl.predict(X, _checks.flag(gradients, "predict: gradients")))

    def __repr__(self) -> str:
        return f"varbo.Model({self.surrogate}, objective={self.objective:.6g}, ok={self.ok})"


def fit(surrogate_config: Config, X: Any, y: Any, *, seed: int = 1, optimize: bool = True,
        threads: int = 0) -> Model:
    """Fits a surrogate (``"gp"``, ``{"type": "vhgp", ...}``, YAML text or file: a surrogate map or a study file's
    ``surrogate:``/``algorithm.surrogate:``) to X (n × d, used as given) and y, exactly as ``varbo fit`` does:
    the same seed gives the same numbers. ``optimize=False`` only conditions on the hyperparameters the config gives
    (``varbo fit --no-optimize``). The GIL is released during the fit."""
    text, name = to_yaml(surrogate_config, "surrogate")
    seed = _checks.integer(seed, "fit: seed", 0, _checks.UINT64_MAX)
    threads = _checks.integer(threads, "fit: threads", 0, 2 ** 31 - 1)
    optimize = _checks.flag(optimize, "fit: optimize")  # bool("no") was True: the fit optimized
    X = _checks.float_array(X, "fit: X")
    if X.ndim == 1:
        X = X.reshape(-1, 1)
    y = _checks.float_array(y, "fit: y")
    if y.ndim > 1 and sum(n > 1 for n in y.shape) > 1:  # two columns were read as twice the values
        raise _checks._input_error(f"fit: y: expected one cost per row of X (a 1-D array), got shape {y.shape}")
    return Model(_varbo._fit(text, name, X, y.ravel(), seed, optimize,
                             threads))
