"""Errors: ConfigError with file:line:col and the key path, and no C++ exception reaching Python as a crash."""
import os

import pytest

import varbo


def test_config_error_from_file(tmp_path):
    cfg = tmp_path / "bad.yaml"
    cfg.write_text("task: {type: branin}\nbudget: 5\nalgorithm:\n  type: bo\n  acquisition: {type: ei, xii: 0.1}\n")
    with pytest.raises(varbo.ConfigError) as e:
        varbo.Study.create(tmp_path / "s.db", str(cfg))
    err = e.value
    assert isinstance(err, ValueError) and isinstance(err, varbo.Error)
    assert err.file == str(cfg) and err.line == 5 and err.column >= 1
    assert err.key == "algorithm.acquisition.xii" and "did you mean 'xi'" in str(err)
    assert not os.path.exists(tmp_path / "s.db")  # nothing written


def test_config_error_from_dict_and_string(tmp_path):
    with pytest.raises(varbo.ConfigError) as e:
        varbo.Study.create(tmp_path / "a.db", {"task": {"type": "branin"}, "budget": -1})
    assert e.value.key == "budget" and e.value.file == "<config dict>"
    with pytest.raises(varbo.UnknownComponentError) as e:
        varbo.Study.create(tmp_path / "b.db", "task: {type: nosuch}\n")
    assert e.value.file == "<config string>" and e.value.line == 1
    with pytest.raises(varbo.ConfigError):  # a YAML syntax error
        varbo.Study.create(tmp_path / "c.db", "task: {type: branin\nbudget: [\n")
    with pytest.raises(varbo.ConfigError, match="missing.yaml"):  # a .yaml path that does not exist
        varbo.Study.create(tmp_path / "d.db", str(tmp_path / "missing.yaml"))
    with pytest.raises(TypeError):
        varbo.Study.create(tmp_path / "e.db", 42)


def test_plugins_and_describe():
    names = {c["name"] for c in varbo.plugins()}
    assert {"bo", "gp", "vhgp", "ei", "branin"} <= names
    kinds = {c["kind"] for c in varbo.plugins("surrogate")}
    assert kinds == {"surrogate"}
    d = varbo.describe("ei")
    assert d["kind"] == "acquisition" and any(o["name"] == "xi" for o in d["options"])
    assert any(o["name"] == "budget" for o in varbo.describe("study")["options"])
    with pytest.raises(varbo.UnknownComponentError, match="did you mean 'ei'"):
        varbo.describe("eii")
    with pytest.raises(varbo.ConfigError):
        varbo.plugins("nokind")


def test_load_plugin_errors(tmp_path):
    with pytest.raises(varbo.InputError):
        varbo.load_plugin(str(tmp_path / "libvarbo_missing.so"))
    junk = tmp_path / "libvarbo_junk.so"
    junk.write_bytes(b"not an ELF file at all")
    with pytest.raises(varbo.PluginLoadError, match="libvarbo_junk.so"):
        varbo.load_plugin(str(junk))
    assert "libvarbo_junk" not in os.environ.get("VARBO_PLUGIN_PATH", "")


def test_set_log_level():
    varbo.set_log_level("info")
    varbo.set_log_level("warn")  # the default after import
    with pytest.raises(varbo.InputError):
        varbo.set_log_level("loud")


# ---- Red-team pass (py11): hostile-but-realistic arguments (scripts/red_team/probe_python.py has every probe) --------
# Each case failed before the pass: a pybind11 "incompatible function arguments" text, a silent int(2.5) or
# float("1.5"), a message naming nothing, a std::bad_alloc, a leaked RecursionError, a wrong result kept.
import copy
import math
import pickle

import numpy as np

_RT_CFG = "task: {type: branin}\nbudget: 8\nseed: 1\nalgorithm: {type: random}\n"
_RT_SPACE = {"x": (-1.0, 1.0), "y": (0.0, 2.0)}
_RT_RANDOM = {"algorithm": {"type": "random"}}


def _rt_quad(p):
    return (p["x"] - 0.3) ** 2 + (p["y"] - 1) ** 2


@pytest.fixture
def rt_study(tmp_path):
    return varbo.Study.create(tmp_path / "s.db", _RT_CFG)


def test_redteam_paths_and_configs(tmp_path):
    for bad in (None, 123):
        with pytest.raises(TypeError, match="path_or_url"):
            varbo.Study.create(bad, _RT_CFG)
        with pytest.raises(TypeError, match="path_or_url"):
            varbo.Study.open(bad)
    with pytest.raises(TypeError, match="config dict"):  # a tuple key: json's message, named
        varbo.Study.create(tmp_path / "a.db", {"task": {"type": "branin"}, (1, 2): 2})
    deep = {}
    c = deep
    for _ in range(5000):
        c["a"] = {}
        c = c["a"]
    with pytest.raises(varbo.ConfigError, match="nested too deeply"):  # was a RecursionError
        varbo.Study.create(tmp_path / "b.db", {"task": {"type": "branin"}, "x": deep})
    assert not os.path.exists(tmp_path / "a.db") and not os.path.exists(tmp_path / "b.db")
    with pytest.raises(TypeError, match="Study.create"):
        varbo.Study(None)
    # A NUL cut the path in C++: a study of another name was created (session 27).
    with pytest.raises(varbo.InputError, match="NUL"):
        varbo.Study.create(str(tmp_path / "c.db\0x"), _RT_CFG)
    with pytest.raises(varbo.InputError, match="NUL"):
        varbo.minimize(lambda x: x[0], [(0, 1)], budget=1, output=str(tmp_path / "run\0x"))
    assert not os.path.exists(tmp_path / "c.db") and not os.path.exists(tmp_path / "run")
    with pytest.raises(varbo.InputError, match="not UTF-8"):  # was pybind11's "incompatible function arguments"
        varbo.Study.create(os.fsdecode(os.fsencode(str(tmp_path)) + b"/lat\xe9in.db"), _RT_CFG)
    with pytest.raises(varbo.InputError, match="in-memory"):  # SQLite's name, not a file: refused
        varbo.Study.create(":memory:", _RT_CFG)


def test_redteam_ask_tell_types(rt_study):
    s = rt_study
    for bad in ("2", 2.5, True, None):
        with pytest.raises(TypeError, match="ask: n"):
            s.ask(bad)
    with pytest.raises(varbo.InputError, match="ask: n"):  # was pybind11's "incompatible function arguments"
        s.ask(10 ** 30)
    assert len(s.ask(np.int64(2))) == 2
    t = s.ask()[0]
    for bad in (None, "1.5", 1 + 2j, np.array([1.0, 2.0]), {"cost": None}):
        with pytest.raises(TypeError, match="cost"):
            s.tell(t, bad)
    with pytest.raises(varbo.InputError, match="cost"):  # was OverflowError
        s.tell(t, 10 ** 400)
    with pytest.raises(TypeError, match="components"):  # a list of pairs was taken as a dict
        s.tell(t, 1.0, [("a", 1.0)])
    with pytest.raises(varbo.InputError, match="unknown trial id"):  # was "incompatible function arguments"
        s.tell(2 ** 70, 1.0)
    with pytest.raises(TypeError, match="Trial"):
        s.tell(True, 1.0)
    assert all(tr.state == "pending" for tr in s.trials(as_frame=False))  # nothing written by a refusal
    s.tell(t, np.array([1.5]))  # a one-element array is a number
    assert s.best().cost == 1.5
    with pytest.raises(varbo.InputError, match="tell_point: x"):  # was numpy's "could not convert string"
        s.tell_point(np.array(["a", 1.0], dtype=object), 1.0)
    with pytest.raises(TypeError, match="tell_point: cost"):
        s.tell_point([1.0, 2.0], "1")
    for bad in (float("nan"), math.inf):  # NaN was a std::bad_alloc (MemoryError) from the C++ selection
        with pytest.raises(varbo.InputError, match="kappa"):
            s.select(bad)
    with pytest.raises(TypeError, match="kappa"):
        s.select("a")
    with pytest.raises(TypeError, match="older_than"):
        s.abandon(None)
    with pytest.raises(TypeError, match="state"):
        s.heartbeat(None)


def test_redteam_copy_and_pickle(rt_study):
    s = rt_study
    with pytest.raises(TypeError, match="Study.open"):
        pickle.dumps(s)
    with pytest.raises(TypeError, match="Study.open"):
        copy.deepcopy(s)
    c = copy.copy(s)  # the same connection
    c.tell(s.ask()[0], 1.0)
    assert s.best().cost == 1.0


def test_redteam_minimize_arguments():
    for kw, exc in [({"budget": "10"}, TypeError), ({"budget": 2.5}, TypeError), ({"budget": True}, TypeError),
                    ({"budget": -1}, varbo.InputError), ({"budget": 10 ** 30}, varbo.InputError),
                    ({"seed": -1}, varbo.InputError), ({"seed": 2 ** 64}, varbo.InputError),
                    # a study stores its seed as an int64: 2^63 ran every trial, then left a study nothing could read
                    ({"seed": 2 ** 63}, varbo.InputError),
                    ({"seed": 1.5}, TypeError), ({"threads": -1}, varbo.InputError), ({"threads": "2"}, TypeError)]:
        name = next(iter(kw))
        with pytest.raises(exc, match=f"minimize: {name}"):
            varbo.minimize(_rt_quad, _RT_SPACE, **kw)
    with pytest.raises(varbo.ConfigError, match="space: x"):  # was "no search space"
        varbo.minimize(_rt_quad, {"x": ("0", "1")}, budget=3)
    with pytest.raises(varbo.ConfigError, match="space: x: the bounds must be finite"):
        varbo.minimize(_rt_quad, {"x": (float("nan"), 1.0)}, budget=3)
    with pytest.raises(varbo.ConfigError, match="space: empty"):
        varbo.minimize(_rt_quad, space=[], budget=3)
    r = varbo.minimize(lambda p: p["x1"] ** 2 + p["x2"] ** 2, np.array([[-1.0, 1.0], [-1.0, 1.0]]), budget=3, seed=1)
    assert r.evaluations == 3  # a (d, 2) array of bounds is a space (was a TypeError about configs)
    assert varbo.minimize(_rt_quad, _RT_SPACE, budget=np.int64(3), seed=np.uint64(2 ** 63 - 1)).evaluations == 3


@pytest.mark.parametrize("ret,word", [(None, "None"), (True, "bool"), (np.bool_(False), "bool")])
def test_redteam_objective_none_or_bool_is_a_failed_trial(ret, word):
    r = varbo.minimize(lambda p: ret, _RT_RANDOM, space=_RT_SPACE, budget=3, seed=1)
    assert r.failed == 3 and all(t.state == "failed" for t in r.trials)
    assert word in r.trials[0].error and "expected a number" in r.trials[0].error


def test_redteam_fit_arguments():
    X = np.random.default_rng(0).uniform(size=(10, 2))
    y = X.sum(1)
    with pytest.raises(varbo.InputError, match="fit: seed"):  # was "incompatible function arguments"
        varbo.fit("gp", X, y, seed=-1)
    with pytest.raises(TypeError, match="fit: seed"):  # was int(1.5) == 1
        varbo.fit("gp", X, y, seed=1.5)
    with pytest.raises(varbo.InputError, match="fit: threads"):
        varbo.fit("gp", X, y, threads=-1)
    Xo = X.astype(object)
    Xo[0, 0] = "a"
    with pytest.raises(varbo.InputError, match="fit: X"):
        varbo.fit("gp", Xo, y)
    m = varbo.fit("gp", X, y, optimize=False)
    with pytest.raises(TypeError, match="predict: X"):
        m.predict("abc")


def test_redteam_optuna_sampler_arguments():
    vo = pytest.importorskip("varbo.optuna")
    with pytest.raises(TypeError, match="VarboSampler: seed"):
        vo.VarboSampler(seed="a")
    with pytest.raises(varbo.InputError, match="VarboSampler: seed"):  # was numpy's "Seed must be between"
        vo.VarboSampler(seed=-1)
    with pytest.raises(varbo.InputError, match="VarboSampler: threads"):
        vo.VarboSampler(seed=1, threads=-1)


def test_redteam_module_functions_name_their_argument(tmp_path):
    # were pybind11's "incompatible function arguments" listings
    with pytest.raises(TypeError, match="set_log_level: level"):
        varbo.set_log_level(None)
    with pytest.raises(TypeError, match="describe: name"):
        varbo.describe(None)
    with pytest.raises(TypeError, match="plugins: kind"):
        varbo.plugins(123)
    with pytest.raises(TypeError, match="load_plugin: path"):
        varbo.load_plugin(None)
    assert varbo.describe("ei")["kind"] == "acquisition" and varbo.plugins("surrogate")


def test_redteam_trial_of_another_study_is_refused(tmp_path):
    # Both studies have a trial 0: telling a's trial to b recorded the result on b's trial 0, silently.
    a = varbo.Study.create(tmp_path / "a.db", _RT_CFG)
    b = varbo.Study.create(tmp_path / "b.db", _RT_CFG)
    ta, tb = a.ask()[0], b.ask()[0]
    with pytest.raises(varbo.InputError, match="a.db"):
        b.tell(ta, 1.0)
    with pytest.raises(varbo.InputError, match="a.db"):
        b.fail(ta, "x")
    assert b.trials(as_frame=False)[0].state == "pending"
    b.tell(tb.id, 1.0)  # an id is taken as this study's
    a2 = varbo.Study.open(tmp_path / "a.db")  # the same store through another object: fine
    a2.tell(ta, 2.0)
    assert a.best().cost == 2.0


def test_redteam_trial_by_another_path_of_the_same_file(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    a = varbo.Study.create("rel.db", _RT_CFG)
    t = a.ask()[0]
    varbo.Study.open(str(tmp_path / "rel.db")).tell(t, 1.0)  # the same file by its absolute path
    assert a.best().cost == 1.0


def test_redteam_minimize_flags_and_budget_zero():
    with pytest.raises(TypeError, match="minimize: progress"):  # was "incompatible function arguments"
        varbo.minimize(_rt_quad, _RT_SPACE, budget=2, progress="yes")
    for b in (0, -1):  # were a silent empty result (fun None, no trial)
        with pytest.raises(varbo.InputError, match="minimize: budget"):
            varbo.minimize(_rt_quad, _RT_SPACE, budget=b)


def test_redteam_study_file_deleted_or_replaced(tmp_path):
    # SQLite wrote on through its open descriptor: results told after `rm` were lost without a word.
    s = varbo.Study.create(tmp_path / "s.db", _RT_CFG)
    t = s.ask(2)
    s.tell(t[0], 1.0)
    os.rename(tmp_path / "s.db", tmp_path / "old.db")
    with pytest.raises(varbo.InputError, match="s.db-wal"):  # a new study here would take in the open one's WAL
        varbo.Study.create(tmp_path / "s.db", _RT_CFG)
    (tmp_path / "s.db").write_text("another file")
    with pytest.raises(varbo.InputError, match="replaced"):
        s.tell(t[1], 2.0)
    assert (tmp_path / "s.db").read_text() == "another file"
    os.remove(tmp_path / "s.db")
    with pytest.raises(varbo.InputError, match="deleted"):
        s.ask()


def test_numpy_values_are_read_as_numbers_never_truncated(tmp_path):
    # Session 20: a 0-d array went through __index__ and was truncated (np.array(2.7) recorded as 2.0), a 1-element
    # array too, and np.bool_ became 1 for an int parameter while a Python bool is refused.
    import numpy as np
    s = varbo.Study.create(tmp_path / "s.db", {"task": {"type": "branin"}, "budget": 5, "seed": 1})
    for bad in (np.array([3.9]), np.array([[1.0]]), np.bool_(True), True):
        with pytest.raises(varbo.InputError, match="parameter 'x2'"):
            s.tell_point({"x1": 2.0, "x2": bad}, 1.0)
    s.tell_point({"x1": np.array(2.7), "x2": np.float32(3.5)}, 1.0)
    s.tell_point({"x1": np.int64(3), "x2": 4}, 2.0)
    assert [t.params for t in s.trials(as_frame=False)] == [{"x1": 2.7, "x2": 3.5}, {"x1": 3.0, "x2": 4.0}]


def test_a_trial_keeps_its_study_across_chdir(tmp_path, monkeypatch):
    # Two studies both called s.db in two folders: a trial asked from one and told after os.chdir is refused by the
    # other and accepted by its own (the origin was a relative path, resolved against the current folder).
    cfg = {"task": {"type": "branin"}, "budget": 5}
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    monkeypatch.chdir(tmp_path / "a")
    a = varbo.Study.create("s.db", cfg)
    ta = a.ask()[0]
    monkeypatch.chdir(tmp_path / "b")
    b = varbo.Study.create("s.db", cfg)
    b.ask()
    with pytest.raises(varbo.InputError, match="belongs to the study"):
        b.tell(ta, 1.0)
    a.tell(ta, 1.0)
    assert varbo.Study.open(tmp_path / "a" / "s.db").trials(as_frame=False)[0].cost == 1.0


def test_parameter_names_of_a_box_are_distinct_strings():
    with pytest.raises(varbo.ConfigError, match="non-empty str"):
        varbo.minimize(lambda p: 0.0, space={1: (0, 1), "1": (5, 6)}, budget=3)
    with pytest.raises(varbo.ConfigError, match="duplicate name 'a'"):
        varbo.minimize(lambda p: 0.0, {"task": {"type": "python", "lower": [0, 5], "upper": [1, 6], "names": ["a", "a"]}},
                       budget=3)


def test_minimize_resume_refuses_another_configuration_and_names_its_own_arguments(tmp_path):
    f = lambda p: (p["x"] - .2) ** 2
    out = tmp_path / "run"
    varbo.minimize(f, {"algorithm": {"type": "random"}}, space={"x": (0, 1)}, budget=4, seed=1, output=out)
    # Another seed is another study: refused, not continued under the new seed (session 20; session 19's
    # adoption of a new resolution had let it through, blaming the plugins).
    with pytest.raises(varbo.InputError, match="different configuration.*seed: 1"):
        varbo.minimize(f, {"algorithm": {"type": "random"}}, space={"x": (0, 1)}, budget=6, seed=2, output=out,
                       resume=True)
    assert len(varbo.Study.open(out / "study.db").trials(as_frame=False)) == 4
    with pytest.raises(varbo.InputError, match="give one"):
        varbo.minimize(f, space={"x": (0, 1)}, budget=6, output=out, resume=True, overwrite=True)
    with pytest.raises(varbo.InputError, match="output="):
        varbo.minimize(f, space={"x": (0, 1)}, budget=6, resume=True)
    # A folder with trials: the hint is minimize's own, not the CLI's (which cannot run a Python objective).
    with pytest.raises(varbo.InputError, match=r"resume=True\).*overwrite=True"):
        varbo.minimize(f, {"algorithm": {"type": "random"}}, space={"x": (0, 1)}, budget=4, seed=1, output=out)


def test_minimize_components_are_declared_on_the_task_and_must_be_finite(tmp_path):
    import math
    f = lambda p: {"cost": p["a"] ** 2, "components": {"energy": p["a"], "bad": math.nan if p["a"] > 0.5 else 1.0}}
    cfg = {"task": {"type": "python", "lower": [0], "upper": [1], "names": ["a"], "components": ["energy", "bad"]},
           "algorithm": {"type": "random"}}
    r = varbo.minimize(f, cfg, budget=6, seed=1, output=tmp_path / "run")
    header = (tmp_path / "run" / "trials.csv").read_text().splitlines()[0]
    assert header.startswith("index,phase,a,cost,ok,energy,bad,")
    for t in r.trials:  # a NaN component fails the trial, saying which, as tell() refuses it
        assert (t.state == "failed") == (t.params["a"] > 0.5)
        if t.state == "failed":
            assert "component 'bad'" in t.error
    # A bool is not a number (session 23: True was stored as 1.0): the trial fails saying so, tell() refuses it.
    flag = lambda p: {"cost": p["a"], "components": {"energy": 1.0, "bad": p["a"] > 0.5}}
    r = varbo.minimize(flag, cfg, budget=4, seed=1, output=tmp_path / "flags")
    assert all(t.state == "failed" and "'bad' is" in t.error and "bool" in t.error for t in r.trials)
    s = varbo.Study.create(tmp_path / "s.db", {"task": {"type": "branin"}, "budget": 5, "seed": 1})
    t = s.ask()[0]
    with pytest.raises(varbo.InputError, match="'fell' is True"):
        s.tell(t, 1.0, {"fell": True})
    assert s.trials(as_frame=False)[0].state == "pending"
    bad = dict(cfg, task=dict(cfg["task"], components=["energy", "cost"]))
    with pytest.raises(varbo.ConfigError, match="names a column of the trials table"):
        varbo.minimize(f, bad, budget=3, output=tmp_path / "other")


def test_yes_no_arguments_refuse_strings_and_a_missing_reason_is_not_none(tmp_path):
    s = varbo.Study.create(tmp_path / "s.db", {"task": {"type": "branin"}, "budget": 5, "seed": 1})
    with pytest.raises(TypeError, match="as_frame"):
        s.trials(as_frame="no")
    t = s.ask()[0]
    s.fail(t, None)
    assert s.trials(as_frame=False)[0].error == "failed"
    with pytest.raises(TypeError, match="reason"):
        s.fail(s.ask()[0], 3)


def test_second_minimize_on_a_running_study_names_the_program_holding_it(tmp_path):
    # Session 23: the lock's message said "another `varbo run`" when a Python minimize held the study.
    import threading
    started, release = threading.Event(), threading.Event()

    def slow(p):
        started.set()
        release.wait(30)
        return p["x"] ** 2

    out = tmp_path / "run"
    first = threading.Thread(target=lambda: varbo.minimize(slow, {"algorithm": {"type": "random"}},
                                                           space={"x": (0, 1)}, budget=2, seed=1, output=out))
    first.start()
    try:
        assert started.wait(30)
        with pytest.raises(varbo.InputError, match=r"in use by another run \((?!varbo run)\S+ pid %d " % os.getpid()):
            varbo.minimize(lambda p: 0.0, {"algorithm": {"type": "random"}}, space={"x": (0, 1)}, budget=4, seed=1,
                           output=out, resume=True)
    finally:
        release.set()
        first.join(60)
    assert len(varbo.Study.open(out / "study.db").trials(as_frame=False)) == 2


def test_fit_optimize_refuses_a_str():
    import numpy as np
    X = np.linspace(0, 1, 8).reshape(-1, 1)
    with pytest.raises(TypeError, match="fit: optimize"):  # bool("no") was True (session 23)
        varbo.fit("gp", X, np.sin(5 * X[:, 0]), optimize="no")
    assert not varbo.fit("gp", X, np.sin(5 * X[:, 0]), optimize=False).optimized


def test_heartbeat_state_is_running_or_stopped(tmp_path):
    # Session 23: any word was stored, and a worker whose state was neither was never abandoned when silent.
    s = varbo.Study.create(tmp_path / "s.db", {"task": {"type": "branin"}, "budget": 5, "seed": 1})
    for bad in ("banana", "Running", ""):
        with pytest.raises(varbo.InputError, match="expected running or stopped"):
            s.heartbeat(bad)
    s.heartbeat()
    s.heartbeat("stopped")


def test_undecodable_text_keeps_the_reason_and_a_0d_label_array_is_its_label(tmp_path):
    # Red team, session 23: the objective's message became pybind11's "Unable to cast Python instance", fail()
    # raised "incompatible function arguments", and np.array("lqr") was refused as "got 'lqr' (type str)".
    import numpy as np

    def f(p):
        raise OSError("cannot read " + os.fsdecode(b"/dev/ttyUSB\xff"))

    r = varbo.minimize(f, {"x": (0, 1)}, budget=1, seed=1, output=tmp_path / "run")
    assert r.trials[0].error.startswith("OSError: cannot read /dev/ttyUSB\\udcff (at ")  # + where it was raised
    s = varbo.Study.create(tmp_path / "s.db", {"task": {"type": "python", "lower": [0], "upper": [1], "names": ["x"]},
                                               "budget": 5})
    s.fail(s.ask()[0], os.fsdecode(b"bad \xff"))
    assert s.trials(as_frame=False)[0].error == "bad \\udcff"
    z = varbo.Study.create(tmp_path / "z.db", {"parameters": [{"name": "solver", "type": "categorical",
                                                               "choices": ["pd", "lqr"]}], "budget": 5})
    tid = z.tell_point({"solver": np.array("lqr")}, 1.0)
    assert z.trials(as_frame=False)[0].params == {"solver": "lqr"} and tid == 0


def test_the_frame_of_a_study_without_trials_has_its_columns(tmp_path):
    pd = pytest.importorskip("pandas")
    s = varbo.Study.create(tmp_path / "e.db", {"parameters": [{"name": "n", "type": "int", "low": 0, "high": 3}],
                                               "budget": 5})
    df = s.trials()
    assert isinstance(df, pd.DataFrame) and len(df) == 0
    assert {"id", "state", "cost", "params_n"} <= set(df.columns)
    assert len(df[df["state"] == "complete"]) == 0


def test_the_python_task_is_described_and_a_missing_folder_is_named(tmp_path):
    # Red team, session 23: describe("python") raised UnknownComponentError; a study file in a folder that does not
    # exist was reported under a temporary name ("x.db.creating-16419: cannot open the study file").
    d = varbo.describe("python")
    assert d["kind"] == "task" and {"lower", "upper", "names", "components"} <= {o["name"] for o in d["options"]}
    assert "python" in [c["name"] for c in varbo.plugins("task")]
    with pytest.raises(varbo.InputError, match=r"x\.db: cannot create the study file: the folder .*nodir does not exist"):
        varbo.Study.create(tmp_path / "nodir" / "x.db", {"task": {"type": "branin"}})
    assert not (tmp_path / "nodir").exists()


def test_a_trial_of_a_minimize_result_is_refused_by_another_study(tmp_path):
    # Red team, session 23: minimize's trials carried no study, and another study's pending trial with the same id
    # took the result silently.
    seen = []
    r = varbo.minimize(lambda p: p["x"], {"x": (0, 1)}, budget=3, seed=1, output=tmp_path / "run",
                       callback=lambda t: seen.append(t))
    other = varbo.Study.create(tmp_path / "other.db", {"task": {"type": "python", "lower": [0], "upper": [1],
                                                                "names": ["x"]}, "budget": 5, "seed": 2})
    other.ask()
    for t in (r.trials[0], seen[0]):
        with pytest.raises(varbo.InputError, match="belongs to the study"):
            other.tell(t, 123.0)
    assert other.trials(as_frame=False)[0].state == "pending"
    varbo.Study.open(tmp_path / "run" / "study.db").trials(as_frame=False)  # its own study still reads them


def test_costs_too_small_for_the_models_are_said(tmp_path, capfd):
    # Red team, session 23: costs of 1e-170 broke the model without a word (large ones were warned about).
    import numpy as np
    varbo.minimize(lambda p: 1e-170 * (1 + p["x"]), {"x": (0, 1)}, budget=2, seed=1, output=tmp_path / "run")
    assert "underflow below about 1e-154" in capfd.readouterr().err
    X = np.linspace(0, 1, 6).reshape(-1, 1)
    with pytest.raises(varbo.InputError, match="every y is at most"):
        varbo.fit("gp", X, 1e-170 * (1 + X[:, 0]))


def test_result_dict_keys_that_are_not_used_are_named(tmp_path, capfd):
    """Red team, session 24: {"cost": c, "component": {...}, "Cost": 99} was accepted and the misspelled keys
    dropped without a word."""
    s = varbo.Study.create(tmp_path / "k.db", {"task": {"type": "branin"}, "budget": 3, "seed": 1})
    t = s.ask()[0]
    with pytest.warns(UserWarning, match=r"'Cost', 'component'.* not used"):
        s.tell(t, {"cost": 1.0, "Cost": 99.0, "component": {"energy": 1.0}})
    assert s.trials(as_frame=False)[0].cost == 1.0
    varbo.minimize(lambda p: {"cost": p["x"] ** 2, "costs": 1.0}, {"x": (-1, 1)}, budget=3, seed=1,
                   output=str(tmp_path / "m"))
    err = capfd.readouterr().err
    assert err.count("the objective's result has the key 'costs', which is not used") == 1
    assert "did you mean 'cost'?" in err


def test_text_that_is_not_utf8_is_named(tmp_path):
    # A lone surrogate (os.fsdecode of a byte that is not UTF-8) gave pybind11's "Unable to cast Python instance"
    # or "incompatible function arguments" (red team, session 31): an InputError naming the argument.
    study = varbo.Study.create(tmp_path / "s.db", {"task": {"type": "branin"}, "budget": 4, "algorithm": "random"})
    (t,) = study.ask()
    with pytest.raises(varbo.InputError, match="components: a name"):
        study.tell(t, 1.0, components={"\udcfc": 1.0})
    with pytest.raises(varbo.InputError, match="a parameter name"):
        study.tell_point({"x\udcfc": 0.5}, 1.0)
    with pytest.raises(varbo.InputError, match="set_worker: name"):
        study.set_worker("w\udcfc")
    study.tell(t, 1.0)  # nothing was written by the refused calls


def test_names_and_labels_beyond_the_basic_plane_in_a_dict(tmp_path):
    # json.dumps wrote an emoji as a surrogate pair ("\\ud83e\\udd16"), which yaml-cpp refuses (red team, session 31).
    cfg = {"parameters": [{"name": "gain", "type": "real", "low": 0, "high": 1},
                          {"name": "mode", "type": "categorical", "choices": ["ü", "日本", "🤖"]}],
           "budget": 6, "seed": 1, "algorithm": "random", "description": "robot 🤖 B"}
    study = varbo.Study.create(tmp_path / "s.db", cfg)
    labels = {study.ask()[0].params["mode"] for _ in range(6)}
    assert labels <= {"ü", "日本", "🤖"} and labels
    r = varbo.minimize(lambda p: p["x🤖"] ** 2, {"x🤖": (-1, 1)}, budget=3, seed=1, output=tmp_path / "m")
    assert set(r.params) == {"x🤖"}


def test_components_given_twice_are_refused(tmp_path):
    """Red team, session 46: tell(t, {"cost": 1, "components": {"e": 1}}, components={"f": 2}) stored {"f": 2}."""
    s = varbo.Study.create(tmp_path / "s.db", {"task": {"type": "branin"}, "budget": 3, "algorithm": {"type": "random"}})
    (t,) = s.ask()
    with pytest.raises(varbo.InputError, match="components given twice"):
        s.tell(t, {"cost": 1.0, "components": {"e": 1.0}}, components={"f": 2.0})
    s.tell(t, {"cost": 1.0, "components": {"e": 1.0}})
    assert [x.state for x in s.trials(as_frame=False)] == ["complete"]


def test_a_failure_reason_is_kept_as_a_task_failure_is(tmp_path):
    """Red team, session 46: Study.fail(t, 'a\\0b') stored 'a'; a 10 MB reason was kept whole, while minimize's
    failed trials kept about 4 KB. Every path now keeps a printable reason of at most 2 KiB at each end."""
    s = varbo.Study.create(tmp_path / "s.db", {"task": {"type": "branin"}, "budget": 3, "algorithm": {"type": "random"}})
    (t,) = s.ask()
    s.fail(t, "a\0b")
    (u,) = s.ask()
    s.fail(u, "x" * 1_000_000)
    errors = [x.error for x in s.trials(as_frame=False)]
    assert errors[0] == "a\\x00b"
    assert errors[1].startswith("x" * 2000) and len(errors[1]) < 5000
