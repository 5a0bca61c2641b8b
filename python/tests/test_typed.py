"""Typed parameters (docs/search_space.md) through the Python package: typed params views, tell_point by name with
the CLI's parsing, minimize on a `parameters:` space, and the Optuna sampler on a typed varbo space."""
import json
import math

import numpy as np
import pytest

import varbo
from conftest import run_cli

PARAMETERS = [
    {"name": "lr", "type": "real", "low": 1.0e-5, "high": 0.1, "log": True},
    {"name": "waypoints", "type": "int", "low": 2, "high": 9},
    {"name": "step", "type": "int", "low": 8, "high": 256, "log": True},
    {"name": "solver", "type": "categorical", "choices": ["pd", "lqr", "mpc"]},
    {"name": "gain", "type": "real", "low": -1, "high": 1},
    {"name": "horizon", "type": "fixed", "value": 3.0},
]
CHOICES = ["pd", "lqr", "mpc"]
ALGORITHM = {"type": "bo", "initial_points": 4, "surrogate": {"type": "gp", "restarts": 1}}


def cost_of(p):
    """A made-up controller cost with its optimum at lr = 1e-3, waypoints = 5, step = 32, solver lqr, gain 0.3."""
    return ((math.log10(p["lr"]) + 3) ** 2 + 0.1 * (p["waypoints"] - 5) ** 2 + (math.log2(p["step"]) - 5) ** 2 / 4
            + {"pd": 1.0, "lqr": 0.0, "mpc": 0.5}[p["solver"]] + (p["gain"] - 0.3) ** 2)


def assert_admissible(params):
    """Right names, types (int for int, str label for categorical, float for real) and bounds."""
    assert sorted(params) == sorted(["lr", "waypoints", "step", "solver", "gain", "horizon"])
    assert isinstance(params["lr"], float) and 1e-5 <= params["lr"] <= 0.1
    assert type(params["waypoints"]) is int and 2 <= params["waypoints"] <= 9
    assert type(params["step"]) is int and 8 <= params["step"] <= 256
    assert isinstance(params["solver"], str) and params["solver"] in CHOICES
    assert isinstance(params["gain"], float) and -1 <= params["gain"] <= 1
    assert params["horizon"] == 3 and type(params["horizon"]) is int  # as the CLI's JSON has it (session 23)


def external_config(budget=12):
    # The external task takes the study's `parameters:`; ask/tell studies never run its command.
    return {"task": {"type": "external", "command": "true"}, "parameters": PARAMETERS, "budget": budget, "seed": 2,
            "algorithm": ALGORITHM}


def test_typed_ask_tell_round_trip_with_cli(tmp_path):
    """Python and the CLI alternate on one typed study: each sees the other's trials with the same typed values
    (the CLI's JSON "params"), and a point told by name from Python equals the same point told with --param."""
    db = tmp_path / "typed.db"
    study = varbo.Study.create(db, external_config())
    assert study.names == [p["name"] for p in PARAMETERS]
    assert [p["type"] for p in study.parameters] == ["real", "int", "int", "categorical", "real", "fixed"]
    assert study.parameters[3]["choices"] == CHOICES
    seen = {}
    for k in range(6):
        if k % 2 == 0:
            (t,) = study.ask()
            assert_admissible(t.params)
            assert list(t.params) == study.names  # in declaration order
            # x is θ in user units: a category by its index.
            assert t.x[3] == CHOICES.index(t.params["solver"]) and t.x[1] == t.params["waypoints"]
            study.tell(t, cost_of(t.params))
            seen[t.id] = t.params
        else:
            (out,) = json.loads(run_cli("suggest", db, "--json").stdout)
            params = out["params"]
            assert_admissible({k: float(v) if k in ("lr", "gain") else v for k, v in params.items()})
            run_cli("observe", db, out["id"], repr(cost_of(params)))
            seen[out["id"]] = params
    trials = {t.id: t for t in study.trials(as_frame=False)}
    assert set(trials) == set(seen)
    for i, params in seen.items():
        assert trials[i].state == "complete"
        assert_admissible(trials[i].params)
        for name, v in params.items():
            assert trials[i].params[name] == v, (i, name)  # CLI JSON and Python views agree exactly
        assert trials[i].cost == pytest.approx(cost_of(params), rel=1e-15)

    # A manual point by name (numpy and Python numbers, a label; the fixed one left out) ...
    point = {"lr": np.float64(1e-3), "waypoints": np.int64(5), "step": 32, "solver": "lqr", "gain": 0.25}
    tid = study.tell_point(point, 0.5)
    manual = {t.id: t for t in study.trials(as_frame=False)}[tid]
    assert manual.phase == "manual" and manual.params == {**{k: v.item() if hasattr(v, "item") else v
                                                             for k, v in point.items()}, "horizon": 3.0}
    assert type(manual.params["waypoints"]) is int
    # ... is the point `varbo observe new --param` records for the same text.
    run_cli("observe", db, "new", "0.5", "--param", "lr=0.001", "--param", "waypoints=5", "--param", "step=32",
            "--param", "solver=lqr", "--param", "gain=0.25")
    last = study.trials(as_frame=False)[-1]
    assert last.phase == "manual" and last.id != tid
    np.testing.assert_array_equal(last.x, manual.x)
    assert last.params == manual.params
    assert study.best().params["solver"] == "lqr"


@pytest.mark.parametrize("change,words", [
    ({"solver": "lqrr"}, ["solver", "lqrr", "did you mean 'lqr'"]),
    ({"waypoints": 4.5}, ["waypoints", "int"]),
    ({"waypoints": 10}, ["waypoints", "not in [2, 9]"]),
    ({"lr": 0.5}, ["lr", "not in"]),
    ({"gain": "high"}, ["gain", "high"]),
    ({"solver": 1}, ["solver", "not one of its choices"]),
    ({"horizon": 4.0}, ["horizon", "fixed"]),
    ({"gain": True}, ["gain", "bool"]),
    ({"gainn": 0.1}, ["gainn", "no parameter", "did you mean 'gain'"]),
])
def test_tell_point_by_name_refuses_bad_values(tmp_path, change, words):
    study = varbo.Study.create(tmp_path / "s.db", external_config())
    point = {"lr": 1e-3, "waypoints": 5, "step": 32, "solver": "lqr", "gain": 0.25}
    point.update(change)
    with pytest.raises(ValueError) as e:
        study.tell_point(point, 1.0)
    assert isinstance(e.value, varbo.InputError)
    for w in words:
        assert w in str(e.value), str(e.value)
    assert "nothing written" in str(e.value)
    assert study.trials(as_frame=False) == []


def test_tell_point_missing_parameter(tmp_path):
    study = varbo.Study.create(tmp_path / "s.db", external_config())
    with pytest.raises(varbo.InputError, match="missing step, solver"):
        study.tell_point({"lr": 1e-3, "waypoints": 5, "gain": 0.0}, 1.0)


def test_box_study_tell_point_by_name_validates(tmp_path):
    """A plain box study: params stay floats, tell_point by name goes through the same parsing (bounds named)."""
    study = varbo.Study.create(tmp_path / "b.db", {"task": {"type": "branin"}, "budget": 5, "seed": 1})
    assert study.parameters is None
    tid = study.tell_point({"x1": 1, "x2": 2.5}, 3.0)
    t = study.trials(as_frame=False)[0]
    assert t.id == tid and t.params == {"x1": 1.0, "x2": 2.5} and isinstance(t.params["x1"], float)
    with pytest.raises(varbo.InputError, match=r"x2.*not in \[0, 15\]"):
        study.tell_point({"x1": 1, "x2": 20}, 3.0)


def test_minimize_typed_space():
    """minimize on `parameters:`: the function gets typed values, every trial is admissible, and the result's params
    are typed; the three ways to give the space agree (the same trials for the same seed)."""
    seen = []

    def fun(p):
        assert_admissible(p)
        seen.append(dict(p))
        return cost_of(p)

    r = varbo.minimize(fun, {"parameters": PARAMETERS, "algorithm": ALGORITHM}, budget=10, seed=4)
    assert r.evaluations == 10 and r.failed == 0 and len(seen) == 10
    assert_admissible(r.params)
    assert_admissible(r.recommended_params)
    assert r.fun == pytest.approx(min(cost_of(p) for p in seen), rel=1e-15)
    assert [t.params for t in r.trials] == seen
    # The same space as space= and as YAML text.
    r2 = varbo.minimize(cost_of, {"algorithm": ALGORITHM}, space=PARAMETERS, budget=10, seed=4)
    yaml_text = ("parameters: " + json.dumps(PARAMETERS) + "\nalgorithm: " + json.dumps(ALGORITHM) + "\n")
    r3 = varbo.minimize(cost_of, yaml_text, budget=10, seed=4)
    assert [t.params for t in r2.trials] == seen and [t.params for t in r3.trials] == seen
    # The run folder's study shows the same typed trials.
    study = varbo.Study.open(r.study_path)
    assert [t.params for t in study.trials(as_frame=False)] == seen


def test_minimize_typed_space_errors():
    with pytest.raises(varbo.ConfigError, match="not both"):
        varbo.minimize(cost_of, {"parameters": PARAMETERS}, space={"x": (0, 1)}, budget=3)
    with pytest.raises(varbo.ConfigError, match="remove this key"):
        varbo.minimize(cost_of, {"parameters": PARAMETERS, "task": {"type": "python", "lower": [0], "upper": [1]}},
                       budget=3)
    with pytest.raises(varbo.ConfigError, match="duplicate parameter name"):
        varbo.minimize(cost_of, [PARAMETERS[0], PARAMETERS[0]], budget=3)


optuna = pytest.importorskip("optuna")


def test_optuna_sampler_on_a_mixed_space():
    """VarboSampler maps float (log), int (log, step 1 and step 3) and categorical distributions onto a typed varbo
    space: relative samples are of the right type and admissible, and every parameter is sampled relatively after
    the first trial (no independent fallback)."""
    import varbo.optuna
    from varbo.optuna import _typed_parameter
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    d = optuna.distributions
    assert _typed_parameter(0, d.IntDistribution(0, 9, step=3)) == {"name": "p0", "type": "int", "low": 0, "high": 3}
    assert _typed_parameter(0, d.FloatDistribution(0, 1, step=0.25)) is None  # the ordinal fallback

    sampler = varbo.optuna.VarboSampler({"type": "bo", "initial_points": 4, "surrogate": {"type": "gp",
                                                                                           "restarts": 1}},
                                        seed=3, warn_independent_sampling=False)
    relative = []
    original = sampler.sample_relative

    def spy(study, trial, space):
        out = original(study, trial, space)
        relative.append(out)
        return out
    sampler.sample_relative = spy

    def objective(trial):
        lr = trial.suggest_float("lr", 1e-5, 1e-1, log=True)
        n = trial.suggest_int("n", 2, 9)
        step = trial.suggest_int("step", 8, 256, log=True)
        k = trial.suggest_int("k", 0, 9, step=3)
        solver = trial.suggest_categorical("solver", ["pd", "lqr", None, 7])
        return cost_of({"lr": lr, "waypoints": n, "step": step, "solver": {None: "mpc", 7: "pd"}.get(solver, solver),
                        "gain": 0.3}) + (k - 6) ** 2 / 10

    study = optuna.create_study(sampler=sampler)
    study.optimize(objective, n_trials=10)
    assert len(study.trials) == 10 and all(t.state == optuna.trial.TrialState.COMPLETE for t in study.trials)
    assert relative[0] == {} and all(relative[1:])  # every trial after the first is sampled relatively
    for r in relative[1:]:
        assert set(r) == {"lr", "n", "step", "k", "solver"}
        assert isinstance(r["lr"], float) and 1e-5 <= r["lr"] <= 1e-1
        assert type(r["n"]) is int and 2 <= r["n"] <= 9
        assert type(r["step"]) is int and 8 <= r["step"] <= 256
        assert type(r["k"]) is int and r["k"] in (0, 3, 6, 9)
        assert r["solver"] in ("pd", "lqr", None, 7)
    for t in study.trials[1:]:
        assert t.params == relative[t.number]


def test_cli_status_and_export_read_a_minimize_study(tmp_path):
    """`varbo status` and `varbo export` open a study varbo.minimize wrote (task `python`), typed values as labels."""
    r = varbo.minimize(cost_of, {"parameters": PARAMETERS, "algorithm": ALGORITHM}, budget=5, seed=1,
                       output=str(tmp_path / "run"))
    status = run_cli("status", r.study_path).stdout
    assert "task python" in status and "5 complete" in status
    import csv
    import io
    rows = list(csv.DictReader(io.StringIO(run_cli("export", r.study_path, "--csv").stdout)))
    assert [int(row["id"]) for row in rows] == [t.id for t in r.trials]
    for row, t in zip(rows, r.trials):
        assert row["solver"] == t.params["solver"] and int(row["waypoints"]) == t.params["waypoints"]
        assert float(row["cost"]) == t.cost


def test_optuna_sampler_falls_back_for_continuous_algorithms():
    """An algorithm without the capability search_space:mixed (rssgd) gets the ordinal encoding, and still returns
    values Optuna accepts (ints integral, within bounds)."""
    import varbo.optuna
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    assert varbo.optuna.VarboSampler(seed=1)._typed
    sampler = varbo.optuna.VarboSampler({"type": "rssgd"}, seed=1, warn_independent_sampling=False)
    assert not sampler._typed
    study = optuna.create_study(sampler=sampler)
    study.optimize(lambda t: (t.suggest_int("n", 0, 5) - 2) ** 2 + t.suggest_float("x", -1, 1) ** 2, n_trials=6)
    for t in study.trials:
        assert type(t.params["n"]) is int and 0 <= t.params["n"] <= 5 and -1 <= t.params["x"] <= 1


def test_a_categorical_of_bools_takes_true_and_false(tmp_path):
    # Red team, session 23: `choices: [True, False]` became the labels "true"/"false", and tell_point refused True.
    # Red team, session 24: the function then gets "true"/"false" (str), where `if p["use_ff"]` is always taken:
    # the labels are kept (the YAML and CLI semantics, and a resumed study's), and a warning says so.
    with pytest.warns(UserWarning, match=r"'use_ff': its choices are labels, so your function receives 'true', "
                                         r"'false' \(str\), not True, False"):
        s = varbo.Study.create(tmp_path / "b.db", {"parameters": [
            {"name": "use_ff", "type": "categorical", "choices": [True, False]},
            {"name": "g", "type": "real", "low": 0, "high": 1}], "budget": 5})
    assert s.parameters[0]["choices"] == ["true", "false"]
    s.tell_point({"use_ff": False, "g": 0.5}, 1.0)
    assert s.trials(as_frame=False)[0].params == {"use_ff": "false", "g": 0.5}
    with pytest.raises(varbo.InputError, match="'g'.*bool"):  # a real parameter still refuses a bool
        s.tell_point({"use_ff": True, "g": True}, 1.0)
