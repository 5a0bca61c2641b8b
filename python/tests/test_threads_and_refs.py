"""Two Python threads with two studies; no references leaked by 1,000 asks."""
import gc
import sys
import threading
import weakref

import numpy as np

import varbo
from conftest import BRANIN_SPACE, branin

CONFIG = {"task": {"type": "branin"}, "budget": 14, "seed": 5,
          "algorithm": {"type": "bo", "initial_points": 5, "surrogate": {"type": "gp", "restarts": 2}}}


def drive(study, n):
    xs = []
    for _ in range(n):
        (t,) = study.ask()
        xs.append(t.x)
        study.tell(t, branin(t.params))
    return np.array(xs)


def test_two_threads_two_studies(tmp_path):
    """Each thread's study reaches the trials it reaches alone; minimize in a third thread meanwhile."""
    alone = drive(varbo.Study.create(tmp_path / "alone.db", CONFIG), 12)
    alone_b = drive(varbo.Study.create(tmp_path / "alone_b.db", dict(CONFIG, seed=6)), 12)
    out, errors = {}, []

    def work(key, path, cfg):
        try:
            out[key] = drive(varbo.Study.create(path, cfg), 12)
        except BaseException as e:  # noqa: BLE001 - reported below
            errors.append(e)

    def run_min():
        try:
            out["min"] = varbo.minimize(branin, {"budget": 8, "seed": 2, "algorithm": CONFIG["algorithm"]},
                                        space=BRANIN_SPACE, output=str(tmp_path / "m")).evaluations
        except BaseException as e:  # noqa: BLE001
            errors.append(e)

    threads = [threading.Thread(target=work, args=("a", tmp_path / "a.db", CONFIG)),
               threading.Thread(target=work, args=("b", tmp_path / "b.db", dict(CONFIG, seed=6))),
               threading.Thread(target=run_min)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors
    np.testing.assert_array_equal(out["a"], alone)
    np.testing.assert_array_equal(out["b"], alone_b)
    assert out["min"] == 8


def test_one_study_shared_by_threads(tmp_path):
    """Concurrent asks on one Study object are serialized: every trial distinct, none lost."""
    s = varbo.Study.create(tmp_path / "s.db", dict(CONFIG, budget=40, algorithm={"type": "random"}))
    ids, errors = [], []

    def work():
        try:
            for _ in range(10):
                (t,) = s.ask()
                ids.append(t.id)
                s.tell(t, 1.0)
        except BaseException as e:  # noqa: BLE001
            errors.append(e)

    th = [threading.Thread(target=work) for _ in range(4)]
    for t in th:
        t.start()
    for t in th:
        t.join()
    assert not errors and sorted(ids) == list(range(40))


def test_no_leaked_references_after_1000_asks(tmp_path):
    s = varbo.Study.create(tmp_path / "s.db", dict(CONFIG, budget=3000, algorithm={"type": "random"}))
    impl = s._impl
    before = (sys.getrefcount(s), sys.getrefcount(impl))  # outside `assert`: pytest's rewriting holds references

    def batch(n):
        last = None
        for _ in range(n):
            (t,) = s.ask()
            s.tell(t, float(t.x.sum()))
            last = weakref.ref(t.x)
        return last

    batch(50)  # warm-up: caches, interned strings
    gc.collect()
    objects_before = len(gc.get_objects())
    last = batch(1000)
    gc.collect()
    assert last() is None  # the arrays handed out are freed
    assert len(gc.get_objects()) - objects_before < 50
    after = (sys.getrefcount(s), sys.getrefcount(impl))
    assert after == before


def test_minimize_keeps_no_references(tmp_path):
    """The objective, the callback and what they return are released after the run."""
    class Cost(float):
        pass

    returned = []

    def fun(p):
        c = Cost(p["x"])
        returned.append(weakref.ref(c))
        return c

    def cb(trial):
        return False

    before = (sys.getrefcount(fun), sys.getrefcount(cb))
    varbo.minimize(fun, {"algorithm": {"type": "random"}}, space={"x": (0, 1)}, budget=200, callback=cb,
                   output=str(tmp_path / "r"))
    gc.collect()
    after = (sys.getrefcount(fun), sys.getrefcount(cb))
    assert after == before
    assert len(returned) == 200 and all(r() is None for r in returned)
