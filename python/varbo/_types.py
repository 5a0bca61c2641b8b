"""The plain records the API returns: trials, selections, predictions, results."""
from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any, Dict, List, Optional, Union

ParamValue = Union[float, int, str]

import numpy as np


def _equal(a, b) -> bool:
    """Value equality that NumPy arrays take part in (the dataclass ``__eq__`` compared them with ``==`` and
    raised "truth value of an array ... is ambiguous" for ``t in study.trials()``)."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return (isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and a.shape == b.shape
                and bool(np.array_equal(a, b)))
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_equal(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return type(a) is type(b) and len(a) == len(b) and all(_equal(x, y) for x, y in zip(a, b))
    return bool(a == b)


class _Record:
    """Records compare field by field, arrays by their values."""

    def __eq__(self, other):
        if other.__class__ is not self.__class__:
            return NotImplemented
        return all(_equal(getattr(self, f.name), getattr(other, f.name)) for f in fields(self))

    __hash__ = None  # mutable records


@dataclass(eq=False)
class Trial(_Record):
    """One trial of a study.

    ``params`` maps each parameter's name to its value in your units (``x1, x2, …`` until the search space names
    them); with typed ``parameters:`` an ``int`` for an int parameter, the label (``str``) of a categorical one, a
    ``float`` for a real one; a fixed value as declared, a number without a fraction as an ``int`` (as the CLI's
    JSON gives it to an external command); ``x`` is the same point as an array, ``x_unit`` in the unit cube the algorithm works in. ``state`` is
    pending, complete, failed or abandoned; ``cost`` is None until a result is told.
    """

    id: int
    state: str
    phase: str
    params: Dict[str, ParamValue]
    x: np.ndarray
    x_unit: np.ndarray
    cost: Optional[float] = None
    components: Dict[str, float] = field(default_factory=dict)
    error: str = ""
    worker: str = ""
    created_at: float = 0.0
    finished_at: float = 0.0
    fit_seconds: float = 0.0
    acquisition_seconds: float = 0.0
    evaluation_seconds: float = 0.0


@dataclass(eq=False)
class Selection(_Record):
    """The evaluated point minimizing E[y] + κ·sqrt(V[y]) under the refitted surrogate (``Study.select``)."""

    kappa: float
    trial_id: int
    params: Dict[str, ParamValue]
    x: np.ndarray
    mean: float
    std: float
    value: float


@dataclass(eq=False)
class Prediction(_Record):
    """The predictive distribution at each row of X, in cost units (Kuindersma 2013, eq. 7).

    ``mean`` E[y]; ``latent_var`` the variance of the latent cost f; ``noise_var`` E[exp g], the expected noise
    variance (constant for a GP); ``variance`` their sum V[y]. With ``gradients=True`` the derivatives with
    respect to x, one row per point: ``d_mean``, ``d_latent_var``, ``d_noise_var``.
    """

    mean: np.ndarray
    latent_var: np.ndarray
    noise_var: np.ndarray
    log_noise_mean: np.ndarray
    log_noise_var: np.ndarray
    d_mean: Optional[np.ndarray] = None
    d_latent_var: Optional[np.ndarray] = None
    d_noise_var: Optional[np.ndarray] = None

    @property
    def variance(self) -> np.ndarray:
        return self.latent_var + self.noise_var

    @property
    def std(self) -> np.ndarray:
        return np.sqrt(self.variance)


@dataclass(eq=False)
class OptimizeResult(_Record):
    """What ``minimize`` returns. ``x``/``fun``/``params``: the best observed point and its cost;
    ``recommended_x``/``recommended_params``: the point the algorithm recommends deploying (bo: the evaluated point
    with the lowest posterior mean by default); ``output``: the run folder (trials.csv, summary.json, study.db)."""

    x: Optional[np.ndarray]
    fun: Optional[float]
    params: Optional[Dict[str, ParamValue]]
    recommended_x: Optional[np.ndarray]
    recommended_params: Optional[Dict[str, ParamValue]]
    recommendation_rule: str
    trials: List[Trial]
    output: str
    evaluations: int
    failed: int
    seconds: float

    @property
    def study_path(self) -> str:
        return self.output + "/study.db"

    @property
    def best(self) -> Optional[Trial]:
        """The complete trial with the lowest cost (the first such by id), as Study.best()."""
        done = [t for t in self.trials if t.state == "complete"]
        return min(done, key=lambda t: t.cost) if done else None

    @property
    def recommended(self) -> Optional[Dict[str, ParamValue]]:
        """The recommended parameters (``recommended_params``)."""
        return self.recommended_params


def trial_from(d: Dict[str, Any]) -> Trial:
    return Trial(**d)
