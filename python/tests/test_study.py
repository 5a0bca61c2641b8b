"""varbo.Study: ask/tell round trips, shared with the CLI on the same study file."""
import csv
import json

import numpy as np
import pytest

import varbo
from conftest import run_cli

CONFIG = {
    "task": {"type": "branin"},
    "budget": 8,
    "seed": 3,
    "algorithm": {"type": "bo", "initial_points": 4, "surrogate": {"type": "gp", "restarts": 1}},
}


def test_create_ask_tell_best(tmp_path):
    study = varbo.Study.create(tmp_path / "s.db", CONFIG)
    assert study.names == ["x1", "x2"]
    assert study.bounds == [(-5.0, 10.0), (0.0, 15.0)]
    costs = {}
    for _ in range(5):
        (trial,) = study.ask()
        assert trial.state == "pending" and set(trial.params) == {"x1", "x2"}
        assert np.array_equal(trial.x, [trial.params["x1"], trial.params["x2"]])
        cost = trial.params["x1"] ** 2 + trial.params["x2"]
        study.tell(trial, cost, components={"a": 1.0})
        costs[trial.id] = cost
    best = study.best()
    assert best.id == min(costs, key=costs.get) and best.cost == min(costs.values())
    assert best.components == {"a": 1.0}
    states = [t.state for t in study.trials(as_frame=False)]
    assert states == ["complete"] * 5


def test_config_forms_agree(tmp_path):
    """A dict, YAML text and a YAML file give the same study (the same first suggestions)."""
    yaml_text = ("task: {type: branin}\nbudget: 8\nseed: 3\n"
                 "algorithm: {type: bo, initial_points: 4, surrogate: {type: gp, restarts: 1}}\n")
    (tmp_path / "c.yaml").write_text(yaml_text)
    firsts = []
    for i, cfg in enumerate([CONFIG, yaml_text, str(tmp_path / "c.yaml"), tmp_path / "c.yaml"]):
        s = varbo.Study.create(tmp_path / f"s{i}.db", cfg)
        firsts.append([t.x for t in s.ask(3)])
    for other in firsts[1:]:
        np.testing.assert_array_equal(np.array(firsts[0]), np.array(other))


def test_round_trip_with_cli(tmp_path):
    """Python asks and tells, the CLI suggests and observes on the same file, each sees the other's trials; and
    the sequence equals a study driven by the CLI alone (same config and seed)."""
    db = tmp_path / "mixed.db"
    study = varbo.Study.create(db, CONFIG)
    f = lambda x: (x[0] - 1.0) ** 2 + (x[1] - 2.0) ** 2  # noqa: E731
    points = []
    for k in range(6):
        if k % 2 == 0:  # Python
            (t,) = study.ask()
            points.append(t.x)
            study.tell(t.id, f(t.x))
        else:  # the CLI on the same file
            out = json.loads(run_cli("suggest", db, "--json").stdout)
            trial = out[0] if isinstance(out, list) else out
            x = np.array(trial["theta"], dtype=float)
            points.append(x)
            run_cli("observe", db, trial["id"], repr(f(x)))
    # Python sees the CLI's results
    trials = study.trials(as_frame=False)
    assert [t.state for t in trials] == ["complete"] * 6
    np.testing.assert_allclose([t.cost for t in trials], [f(p) for p in points], rtol=0, atol=0)
    status = run_cli("status", db).stdout
    assert "6" in status
    # The same study driven by the CLI alone suggests the same points.
    cli_db = tmp_path / "cli.db"
    cfg = tmp_path / "c.json"
    cfg.write_text(json.dumps(CONFIG))
    run_cli("study", "create", cli_db, cfg)
    for p in points:
        out = json.loads(run_cli("suggest", cli_db, "--json").stdout)
        trial = out[0] if isinstance(out, list) else out
        np.testing.assert_allclose(trial["theta"], p, rtol=0, atol=1e-12)
        run_cli("observe", cli_db, trial["id"], repr(f(np.array(trial["theta"]))))


def test_open_continues(tmp_path):
    db = tmp_path / "s.db"
    s = varbo.Study.create(db, CONFIG)
    (t,) = s.ask()
    s.tell(t, 1.5)
    (pending,) = s.ask()
    del s
    s2 = varbo.Study.open(db)
    assert [t.state for t in s2.trials(as_frame=False)] == ["complete", "pending"]
    s2.tell(pending.id, {"cost": 2.0, "components": {"e": 0.5}})
    assert s2.trials(as_frame=False)[1].components == {"e": 0.5}


def test_fail_and_budget(tmp_path):
    s = varbo.Study.create(tmp_path / "s.db", dict(CONFIG, budget=3, algorithm={"type": "random"}))
    a, b = s.ask(2)
    s.fail(a, "robot fell")
    s.tell(b, 1.0)
    (c,) = s.ask(5)  # one left in the budget
    s.tell(c, 2.0)
    assert s.ask() == []
    t = s.trials(as_frame=False)
    assert t[0].state == "failed" and t[0].error == "robot fell" and t[0].cost is None


def test_retract_failures_takes_back_a_rig_outage(tmp_path):
    # Session 48: failures that were the rig's fault taught bo's failure model for the rest of the study; taken back,
    # the algorithm is rebuilt without them: a bo study then asks what it asks in a study that never saw them.
    cfg = dict(CONFIG, budget=8, algorithm={"type": "bo", "initial_points": 4})
    s = varbo.Study.create(tmp_path / "s.db", cfg)
    (a,) = s.ask()
    s.fail(a, "E-stop pressed")
    (b,) = s.ask()
    s.fail(b, "E-stop pressed")
    other = varbo.Study.open(tmp_path / "s.db")  # another driver of the study, its algorithm built before:
    assert other.recommendation() is None       # (brought up to date: told the two failures)
    assert s.retract_failures([a.id, b.id], "E-stop") == [a.id, b.id]
    t = s.trials(as_frame=False)
    assert t[0].state == "failed" and t[0].error.startswith("taken back by `varbo retract` (E-stop)")
    with pytest.raises(varbo.InputError, match="taken back already"):
        s.retract_failures([a.id])
    with pytest.raises(TypeError):
        s.retract_failures(3)
    # The same algorithm and seed in a study that never saw the failures asks the same next point; so does the other
    # open driver, which notices the retraction at its next ask (audit, session 48: it went on with the failures).
    fresh = varbo.Study.create(tmp_path / "f.db", cfg)
    first = fresh.ask()[0].params
    assert other.ask()[0].params == first
    # Only bo learns where trials fail: another algorithm's study is refused, nothing written.
    r = varbo.Study.create(tmp_path / "r.db", dict(CONFIG, budget=4, algorithm={"type": "random"}))
    (c,) = r.ask()
    r.fail(c, "E-stop")
    with pytest.raises(varbo.InputError, match="keeps no model of where trials fail"):
        r.retract_failures([c.id])


def test_fail_point_records_a_hand_tried_failure(tmp_path):
    s = varbo.Study.create(tmp_path / "s.db", CONFIG)
    i = s.fail_point({"x1": 1.0, "x2": 2.0}, "robot fell")
    j = s.fail_point(np.array([3.0, 4.0]))
    t = s.trials(as_frame=False)
    assert (t[i].state, t[i].phase, t[i].error, t[i].cost) == ("failed", "manual", "robot fell", None)
    assert t[i].params == {"x1": 1.0, "x2": 2.0}
    assert (t[j].state, t[j].error) == ("failed", "failed")
    with pytest.raises(varbo.InputError, match="outside the domain"):
        s.fail_point([100.0, 2.0], "x")
    with pytest.raises(varbo.InputError, match="x3"):
        s.fail_point({"x1": 1.0, "x2": 2.0, "x3": 1.0})
    with pytest.raises(TypeError):
        s.fail_point([1.0, 2.0], 5)
    assert len(s.trials(as_frame=False)) == 2  # nothing written by the refused calls
    # the CLI reads the same record
    out = run_cli("export", str(tmp_path / "s.db"), "--csv").stdout
    assert "manual" in out and "robot fell" in out


def test_recommendation_matches_the_run_summary(tmp_path):
    # What `varbo run` writes to summary.json, asked of the finished study opened afresh (the algorithm is rebuilt).
    cfg = tmp_path / "c.yaml"
    cfg.write_text(json.dumps(dict(CONFIG, budget=10)))
    run_cli("-q", "run", str(cfg), "-o", str(tmp_path / "run"), "--no-progress")
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    study = varbo.Study.open(tmp_path / "run" / "study.db")
    rec = study.recommendation()
    assert rec is not None and list(rec) == ["x1", "x2"]
    assert [rec["x1"], rec["x2"]] == summary["recommended_theta"]
    empty = varbo.Study.create(tmp_path / "e.db", CONFIG)
    assert empty.recommendation() is None


def test_select_kappas(tmp_path):
    s = varbo.Study.create(tmp_path / "s.db", dict(CONFIG, algorithm={"type": "random"}, budget=12))
    rng = np.random.default_rng(0)
    for t in s.ask(10):
        s.tell(t, float(t.params["x1"] ** 2 + rng.normal(0, 0.1)))
    sel = s.select([2.0, -2.0])
    assert [x.kappa for x in sel] == [2.0, -2.0]
    for x in sel:
        assert x.value == pytest.approx(x.mean + x.kappa * x.std)
        assert x.params == dict(zip(s.names, x.x.tolist()))
    one = s.select(0.0)
    assert one.value == pytest.approx(one.mean)


def test_tell_point_and_errors(tmp_path):
    s = varbo.Study.create(tmp_path / "s.db", CONFIG)
    i = s.tell_point({"x1": 1.0, "x2": 2.0}, 3.0)
    assert s.trials(as_frame=False)[i].phase == "manual"
    with pytest.raises(varbo.InputError):
        s.tell_point([100.0, 2.0], 3.0)  # outside the domain
    (t,) = s.ask()
    with pytest.raises(ValueError, match="finite"):
        s.tell(t, float("nan"))
    with pytest.raises(varbo.InputError, match="no trial with id"):
        s.tell(999, 1.0)
    s.tell(t, 1.0)
    with pytest.raises(varbo.InputError, match="already complete"):
        s.tell(t, 1.0)
    with pytest.raises(TypeError):
        s.tell("x", 1.0)
    with pytest.raises(varbo.InputError):
        varbo.Study.create(tmp_path / "s.db", CONFIG)  # exists
    with pytest.raises(varbo.InputError):
        varbo.Study.open(tmp_path / "missing.db")


def test_trials_dataframe_when_pandas(tmp_path):
    pd = pytest.importorskip("pandas")
    s = varbo.Study.create(tmp_path / "s.db", CONFIG)
    (t,) = s.ask()
    s.tell(t, 1.0)
    df = s.trials()
    assert isinstance(df, pd.DataFrame) and list(df["params_x1"]) == [t.params["x1"]]


def test_a_study_of_your_own_parameters_for_ask_tell_and_the_cli(tmp_path):
    # Session 20: Study.create refused the task `python` and a config with `parameters:` but no task, so an ask/tell
    # study over one's own space had to borrow a benchmark's domain; the CLI's suggest refused a study that minimize
    # wrote ("unknown task 'python'").
    from conftest import run_cli
    s = varbo.Study.create(tmp_path / "own.db", {"parameters": [
        {"name": "gain", "type": "real", "low": 0, "high": 10},
        {"name": "mode", "type": "categorical", "choices": ["pd", "lqr"]}], "budget": 4, "seed": 1})
    t = s.ask()[0]
    assert 0 <= t.params["gain"] <= 10 and t.params["mode"] in ("pd", "lqr")
    s.tell(t, 1.5)
    box = varbo.Study.create(tmp_path / "box.db", {"task": {"type": "python", "lower": [0], "upper": [1],
                                                            "names": ["k"]}, "budget": 3})
    assert list(box.ask()[0].params) == ["k"]
    r = run_cli("suggest", tmp_path / "own.db")
    assert "gain=" in r.stdout and "mode=" in r.stdout
    out = tmp_path / "run"
    varbo.minimize(lambda p: p["x"] ** 2, space={"x": (-1, 1)}, budget=3, seed=1, output=out)
    r = run_cli("suggest", out / "study.db", check=False)
    assert r.returncode == 4 and "budget" in r.stderr and "unknown task" not in r.stderr  # 4: nothing to suggest


def test_result_ok_false_is_a_failed_trial(tmp_path):
    # {"cost": 1e9, "ok": False} was recorded as a success with cost 1e9 (red team, session 31).
    study = varbo.Study.create(tmp_path / "s.db", {"task": {"type": "branin"}, "budget": 4, "algorithm": "random"})
    (t,) = study.ask()
    study.tell(t, {"cost": 1e9, "ok": False, "reason": "robot fell"})
    (rec,) = study.trials(as_frame=False)
    assert rec.state == "failed" and "robot fell" in rec.error
    (t,) = study.ask()
    with pytest.raises(TypeError, match="'ok'"):
        study.tell(t, {"cost": 1.0, "ok": "no"})
    study.tell(t, {"cost": 1.0, "ok": True})
    r = varbo.minimize(lambda p: {"cost": 1e9, "ok": False, "reason": "fell"} if p["x"] < 0 else p["x"] ** 2,
                       {"x": (-1, 1)}, budget=6, seed=2, output=tmp_path / "m")
    with open(tmp_path / "m" / "trials.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    bad = [row for row in rows if float(row["x"]) < 0]
    assert bad and all(row["ok"] == "0" and "fell" in row["error"] for row in bad)
    assert all(float(row["cost"]) < 1e9 for row in rows if row["ok"] == "1")
    assert r is not None


def test_create_from_a_file_with_parameters_only(tmp_path):
    # Study.create refused a file with `parameters:` and no task ("key 'task': missing required key"), which
    # minimize and the same text accepted (red team, session 31).
    cfg = tmp_path / "p.yaml"
    cfg.write_text("parameters:\n  - {name: gain, type: real, low: 0, high: 2}\n  - {name: n, type: int, low: 1, high: 4}\n"
                   "budget: 3\nalgorithm: random\n")
    study = varbo.Study.create(tmp_path / "s.db", cfg)
    assert study.names == ["gain", "n"]


def test_a_fit_on_noisy_costs_does_not_abort_the_process(tmp_path):
    # These 9 costs (a noisy rig, red team session 31) made the 10th ask's gp fit (se_ard) hit a fatal CHECK in
    # Ceres' line search: SIGABRT, and the study could never be continued. A huge gradient is now a failed step.
    costs = [2.3362093055135227, 2.2223661214983217, 1.267020120177826, 1.942295788195092, 1.5897087075585548,
             1.737275124708863, 1.3284429376432434, 1.3507568029893595, 1.3862245177095078]
    cfg = {"task": {"type": "external", "command": "false", "dim": 2, "bounds": [0, 1]}, "budget": 30, "seed": 2,
           "threads": 1, "algorithm": {"type": "bo", "surrogate": {"type": "gp", "kernel": "se_ard"}}}
    study = varbo.Study.create(tmp_path / "s.db", cfg)
    for c in costs:
        (t,) = study.ask()
        study.tell(t, c)
    (t,) = study.ask()
    assert all(0 <= v <= 1 for v in t.x)
