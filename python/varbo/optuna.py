"""``VarboSampler``: varbo's Bayesian optimization as an Optuna sampler.

    import optuna, varbo.optuna
    study = optuna.create_study(sampler=varbo.optuna.VarboSampler(seed=1))   # the one line that changes
    study.optimize(objective, n_trials=100)

Optuna keeps its storage, pruners, dashboard and visualizations; varbo only chooses the points. Relative sampling
covers the intersection search space of the finished trials (every parameter all of them had, with the same
distribution). That space becomes a typed varbo search space (docs/search_space.md): FloatDistribution → a
``real`` parameter (``log`` kept), IntDistribution with step 1 → an ``int`` parameter (``log`` kept), with a step
s > 1 (no log) → an ``int`` index k, the value being low + k·s, CategoricalDistribution → a ``categorical``
parameter (one-hot with argmax in the model, as the typed spaces do). The finished trials are told to a varbo
algorithm (``{type: bo}`` unless ``algorithm`` says otherwise: any varbo algorithm that handles typed spaces) and
its next admissible point is asked. A space varbo cannot type (a FloatDistribution with ``step``), and any space when
the algorithm does not handle mixed spaces (no capability ``search_space:mixed``), falls back to an ordinal encoding of the whole space on [0, 1]^d (floats linearly or in log scale, integers and steps by rounding,
categoricals by the index of the choice). Failed trials are told as failures (bo's failure model avoids where
trials fail); pruned trials at their last reported intermediate value (as failures when they reported none);
pending trials are passed as pending points. One sampler may serve several studies: each has its own state. Parameters outside that space (the first trial,
conditional parameters) come from the independent sampler (Optuna's RandomSampler by default).
"""
from __future__ import annotations

import json
import math
import threading
from typing import Any, Dict, List, Optional, Sequence

import numpy as np
import optuna
from optuna.distributions import BaseDistribution, CategoricalDistribution, FloatDistribution, IntDistribution
from optuna.samplers import BaseSampler, RandomSampler
from optuna.study import StudyDirection
from optuna.trial import FrozenTrial, TrialState

from . import _checks, _varbo
from ._config import to_yaml

try:  # Optuna >= 3.2 moved it
    from optuna.search_space import IntersectionSearchSpace
except ImportError:  # pragma: no cover - Optuna 3.1 (Debian 12)
    from optuna.samplers import IntersectionSearchSpace

__all__ = ["VarboSampler"]


def _encode(dist: BaseDistribution, value: Any) -> float:
    """A parameter value as a coordinate in [0, 1]."""
    if isinstance(dist, CategoricalDistribution):
        n = len(dist.choices)
        return (dist.to_internal_repr(value) + 0.5) / n
    low, high = float(dist.low), float(dist.high)
    v = float(value)
    if isinstance(dist, IntDistribution) and not dist.log:
        # Integer k owns [k - step/2, k + step/2]: every integer gets the same share of the unit interval.
        s = dist.step
        return (v - low + 0.5 * s) / (high - low + s)
    if dist.log:
        return (math.log(v) - math.log(low)) / (math.log(high) - math.log(low))
    return (v - low) / (high - low)


def _decode(dist: BaseDistribution, u: float) -> Any:
    """The value at coordinate u in [0, 1] (the inverse of _encode, rounded to the distribution's grid)."""
    u = min(max(float(u), 0.0), 1.0)
    if isinstance(dist, CategoricalDistribution):
        n = len(dist.choices)
        return dist.to_external_repr(min(int(u * n), n - 1))
    low, high = float(dist.low), float(dist.high)
    if isinstance(dist, IntDistribution):
        if dist.log:
            v = math.exp(math.log(low) + u * (math.log(high) - math.log(low)))
            return int(min(max(round(v), dist.low), dist.high))
        s = dist.step
        k = math.floor(u * (high - low + s) / s)
        return int(min(dist.low + k * s, dist.high - (dist.high - dist.low) % s))
    if dist.log:
        v = math.exp(math.log(low) + u * (math.log(high) - math.log(low)))  # low and high up to rounding
    else:
        v = low + u * (high - low)
    if dist.step is not None:
        v = low + round((v - low) / dist.step) * dist.step
    return float(min(max(v, low), high))


def _typed_parameter(i: int, dist: BaseDistribution) -> Optional[Dict[str, Any]]:
    """The varbo parameter declaration of an Optuna distribution (named p<i>: Optuna's names need not be
    identifiers), or None when varbo's typed spaces cannot represent it exactly."""
    name = f"p{i}"
    if isinstance(dist, CategoricalDistribution):
        # Labels of our own: Optuna's choices may be None, numbers or booleans; the index maps back.
        return {"name": name, "type": "categorical", "choices": [f"c{j}" for j in range(len(dist.choices))]}
    if isinstance(dist, IntDistribution):
        if max(abs(int(dist.low)), abs(int(dist.high))) > 2 ** 53:
            return None  # beyond varbo's exact integers (doubles): the ordinal fallback, as for any other gap
        if dist.step == 1:
            return {"name": name, "type": "int", "low": int(dist.low), "high": int(dist.high), "log": bool(dist.log)}
        if not dist.log:
            return {"name": name, "type": "int", "low": 0, "high": (int(dist.high) - int(dist.low)) // int(dist.step)}
        return None
    if isinstance(dist, FloatDistribution) and dist.step is None:
        return {"name": name, "type": "real", "low": float(dist.low), "high": float(dist.high), "log": bool(dist.log)}
    return None


def _to_theta(dist: BaseDistribution, value: Any) -> float:
    """An Optuna value as θ of its typed varbo parameter (a category by its index)."""
    if isinstance(dist, CategoricalDistribution):
        return float(dist.to_internal_repr(value))
    if isinstance(dist, IntDistribution) and dist.step != 1:
        return float((int(value) - int(dist.low)) // int(dist.step))
    return float(value)


def _from_theta(dist: BaseDistribution, t: float) -> Any:
    """The Optuna value of θ (admissible: integral for int parameters and categories)."""
    if isinstance(dist, CategoricalDistribution):
        return dist.to_external_repr(int(round(t)))
    if isinstance(dist, IntDistribution):
        k = int(round(t))
        return int(dist.low) + k * int(dist.step) if dist.step != 1 else min(max(k, int(dist.low)), int(dist.high))
    return float(min(max(float(t), float(dist.low)), float(dist.high)))


class _StudyState:
    """What the sampler keeps for one study (see VarboSampler.__init__)."""

    def __init__(self) -> None:
        self.search_space = IntersectionSearchSpace()
        self.alg: Optional[_varbo._Algorithm] = None
        self.alg_key: Optional[tuple] = None
        self.told: List[int] = []
        self.handed_out: Dict[int, tuple] = {}  # trial number -> (search space key, unit point) while running
        self.said_empty = False
        self.said_scale = False


def _told_cost(t: FrozenTrial, sign: float) -> float:
    """The cost a finished trial is told with (NaN: told as a failure).

    A pruned trial was stopped because it did not look promising: it is told at its last reported intermediate
    value, as Optuna's TPE ranks it, or as a failure when it reported none. Before, pruned trials were not told at
    all, and the unchanged algorithm proposed the pruned point again for the rest of the study (red team,
    session 24)."""
    if t.state == TrialState.COMPLETE:
        return sign * t.value if t.value is not None else math.nan
    if t.state == TrialState.PRUNED and t.intermediate_values:
        v = t.intermediate_values[max(t.intermediate_values)]
        return sign * float(v) if v is not None and math.isfinite(float(v)) else math.nan
    return math.nan


def _interrupted(t: FrozenTrial) -> bool:
    """A trial Optuna marked failed because the user pressed Ctrl-C (KeyboardInterrupt), where Optuna records why
    (its ``fail_reason`` system attribute; Optuna 3.1 records nothing, and such a trial is told as a failure)."""
    return t.state == TrialState.FAIL and "KeyboardInterrupt" in str(t.system_attrs.get("fail_reason", ""))


class VarboSampler(BaseSampler):
    """An Optuna sampler choosing points with a varbo algorithm (default: varbo's plain ``{type: bo}``).

    Args:
        algorithm: a varbo algorithm configuration (dict, YAML text or file), e.g.
            ``{"type": "bo", "surrogate": {"type": "vhgp"}, "acquisition": {"type": "ei", "xi": 0.1}}``.
        seed: the algorithm's seed (and the independent sampler's); a random one when None.
        independent_sampler: for parameters outside the intersection search space (default RandomSampler(seed)).
        budget: the number of trials the study will run, if known: bo caps its initial design by it and spends the
            last d + 1 trials refining the best point (0: unknown; docs/python.md shows what that costs).
        threads: worker threads of the C++ engine (0 = all cores).
        warn_independent_sampling: warn when a parameter is sampled independently after the first trial.
    """

    def __init__(self, algorithm: Any = None, *, seed: Optional[int] = None,
                 independent_sampler: Optional[BaseSampler] = None, budget: int = 0, threads: int = 0,
                 warn_independent_sampling: bool = True) -> None:
        self._yaml, self._yaml_name = to_yaml(algorithm if algorithm is not None else {"type": "bo"}, "algorithm")
        # Optuna's RandomSampler (the default independent sampler) takes seeds in [0, 2^32 - 1].
        self._seed = (_checks.integer(seed, "VarboSampler: seed", 0, 2 ** 32 - 1) if seed is not None
                      else int(np.random.SeedSequence().generate_state(1)[0]))
        self._independent = independent_sampler or RandomSampler(seed=self._seed)
        self._budget = _checks.integer(budget, "VarboSampler: budget", 0)
        self._threads = _checks.integer(threads, "VarboSampler: threads", 0, 2 ** 31 - 1)
        self._warn = warn_independent_sampling
        # One entry per study this sampler serves (one sampler passed to two studies mixed their trials: the second
        # study was handed the first one's points; red team, session 24): its intersection search space, the live
        # algorithm and the trial numbers told to it, in order (a later call that only adds results tells those, as
        # a varbo study does, instead of refitting from scratch), and the points handed out to running trials.
        self._studies: Dict[tuple, _StudyState] = {}
        self._lock = threading.Lock()  # study.optimize(n_jobs > 1) samples from several threads
        # Configuration errors surface here, not at the first relative sample.
        _varbo._Algorithm(self._yaml, self._yaml_name, 1, self._seed, self._budget, self._threads)
        # An algorithm without the capability search_space:mixed (e.g. trust_region) gets the ordinal encoding.
        try:
            _varbo._Algorithm(self._yaml, self._yaml_name, 1, self._seed, self._budget, self._threads,
                              '[{name: k, type: int, low: 0, high: 1}]')
            self._typed = True
        except _varbo.ConfigError as e:
            if "search_space:mixed" not in str(e):
                raise
            self._typed = False

    def reseed_rng(self) -> None:
        self._independent.reseed_rng()

    def __getstate__(self) -> Dict[str, Any]:
        # The live algorithm (C++) is not pickled: the next relative sample rebuilds it from the study's trials.
        state = self.__dict__.copy()
        state.update(_studies={}, _lock=None)
        return state

    def __setstate__(self, state: Dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._lock = threading.Lock()

    def infer_relative_search_space(self, study: optuna.Study, trial: FrozenTrial) -> Dict[str, BaseDistribution]:
        if study._is_multi_objective():
            return {}
        space = {}
        with self._lock:
            per_study = self._state_of(study)
        for name, dist in per_study.search_space.calculate(study).items():
            if dist.single():
                continue  # nothing to choose
            space[name] = dist
        return space

    def _state_of(self, study: optuna.Study) -> "_StudyState":
        key = (id(study._storage), study._study_id)
        if key not in self._studies:
            self._studies[key] = _StudyState()
        return self._studies[key]

    def sample_relative(self, study: optuna.Study, trial: FrozenTrial,
                        search_space: Dict[str, BaseDistribution]) -> Dict[str, Any]:
        if not search_space:
            return {}
        with self._lock:
            return self._sample_relative(study, trial, search_space)

    def _sample_relative(self, study: optuna.Study, trial: FrozenTrial,
                         search_space: Dict[str, BaseDistribution]) -> Dict[str, Any]:
        names = sorted(search_space)
        sign = -1.0 if study.direction == StudyDirection.MAXIMIZE else 1.0
        key = (tuple(names), tuple(repr(search_space[n]) for n in names), sign)
        typed = [_typed_parameter(i, search_space[n]) for i, n in enumerate(names)]
        parameters = json.dumps(typed, ensure_ascii=False) if self._typed and all(p is not None for p in typed) else ""
        if parameters:
            def encode(n: str, v: Any) -> float:
                return _to_theta(search_space[n], v)

            def decode(n: str, t: float) -> Any:
                return _from_theta(search_space[n], t)
        else:  # the ordinal fallback on [0, 1]^d
            def encode(n: str, v: Any) -> float:
                return _encode(search_space[n], v)

            def decode(n: str, t: float) -> Any:
                return _decode(search_space[n], t)
        def admissible(t: FrozenTrial) -> bool:
            # A trial enqueued by hand may hold values outside the distributions (Optuna warns and runs it); the
            # model leaves it out instead of refusing the whole study ("p1 = 1.5 is not in [0, 1]").
            for n in names:
                if n not in t.params:
                    return False
                try:
                    if not search_space[n]._contains(search_space[n].to_internal_repr(t.params[n])):
                        return False
                except (ValueError, TypeError):
                    return False
            return True

        st = self._state_of(study)
        trials = study.get_trials(deepcopy=False, states=(TrialState.COMPLETE, TrialState.FAIL, TrialState.PRUNED,
                                                          TrialState.RUNNING))
        done: List[FrozenTrial] = []
        pending: List[List[float]] = []
        for t in trials:
            if t.number == trial.number:
                continue
            if t.state == TrialState.RUNNING:
                # A point this sampler handed out is pending even before its trial stores it (Optuna sets a
                # relative sample's params only when the objective suggests them).
                if t.number in st.handed_out and st.handed_out[t.number][0] == key:
                    pending.append(st.handed_out[t.number][1])
                elif admissible(t):
                    pending.append([encode(n, t.params[n]) for n in names])
            elif _interrupted(t):
                continue  # like a varbo trial abandoned: not the point's fault; it may be suggested again
            elif admissible(t):
                done.append(t)
        running = {t.number for t in trials if t.state == TrialState.RUNNING}
        st.handed_out = {k: v for k, v in st.handed_out.items() if k in running}
        done.sort(key=lambda t: (t.datetime_complete or t.datetime_start, t.number))
        numbers = [t.number for t in done]
        if st.alg is None or st.alg_key != key or numbers[:len(st.told)] != st.told:
            st.alg = _varbo._Algorithm(self._yaml, self._yaml_name, len(names), self._seed, self._budget,
                                       self._threads, parameters)
            st.alg_key = key
            st.told = []
        new = done[len(st.told):]
        if new:
            X = np.array([[encode(n, t.params[n]) for n in names] for t in new], dtype=float)
            y = np.array([_told_cost(t, sign) for t in new], dtype=float)
            big = np.abs(y[np.isfinite(y)])
            tiny = big[(big > 0) & (big < 1e-150)]
            if not st.said_scale and (np.any(big > 1e150) or tiny.size):
                # As varbo.Study and minimize say it (the Optuna path said nothing; red team, session 24).
                st.said_scale = True
                optuna.logging.get_logger(__name__).warning(
                    f"VarboSampler: a cost of magnitude {float(big.max() if np.any(big > 1e150) else tiny.min()):g}: "
                    f"the models work with squared costs (variances), which overflow beyond about 1e154 and "
                    f"underflow below about 1e-154; rescale the objective (e.g. divide by a constant or take its log)")
            for i in range(len(new)):  # one result per tell, in finish order, as a varbo study tells them
                st.alg.tell(X[i:i + 1], y[i:i + 1])
            st.told.extend(t.number for t in new)
        st.alg.set_pending(np.array(pending, dtype=float).reshape(-1, len(names)))
        X, _phases = st.alg.ask(1)
        if len(X) == 0:
            if not st.said_empty:
                st.said_empty = True
                optuna.logging.get_logger(__name__).warning(
                    f"VarboSampler: the varbo algorithm returned no point for trial {trial.number} (its budget, "
                    f"{self._budget or 'none given'}, is used, or it has converged); from now on the parameters "
                    f"come from {type(self._independent).__name__}")
            return {}
        st.handed_out[trial.number] = (key, X[0].tolist())
        if pending:
            # As varbo::Study does: an algorithm asked with pending points is not continued (its state after such
            # an ask is not the serial one); the next sample rebuilds it from the finished trials.
            st.alg = None
        return {n: decode(n, u) for n, u in zip(names, X[0])}

    def sample_independent(self, study: optuna.Study, trial: FrozenTrial, param_name: str,
                           param_distribution: BaseDistribution) -> Any:
        if self._warn and trial.number > 0 and not study._is_multi_objective():
            optuna.logging.get_logger(__name__).warning(
                f"VarboSampler: parameter '{param_name}' of trial {trial.number} is outside the intersection search "
                f"space; sampled by {type(self._independent).__name__}")
        return self._independent.sample_independent(study, trial, param_name, param_distribution)
