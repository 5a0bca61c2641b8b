"""One study, two worker processes: each asks, evaluates and tells on the same study file (SQLite; one machine).

    PYTHONPATH=build/python /usr/bin/python3 examples/python/two_workers.py

The parent creates the study and starts two workers (multiprocessing, "spawn"); every trial one worker asks is
pending for the other, so the two never evaluate the same point; the budget is shared.
"""
import math
import multiprocessing as mp
import os
import tempfile
import time

import varbo


def hartmann3(x):
    A = [[3.0, 10, 30], [0.1, 10, 35], [3.0, 10, 30], [0.1, 10, 35]]
    P = [[0.3689, 0.1170, 0.2673], [0.4699, 0.4387, 0.7470], [0.1091, 0.8732, 0.5547], [0.0381, 0.5743, 0.8828]]
    alpha = [1.0, 1.2, 3.0, 3.2]
    return -sum(a * math.exp(-sum(A[i][j] * (x[j] - P[i][j]) ** 2 for j in range(3))) for i, a in enumerate(alpha))


def worker(path, name):
    study = varbo.Study.open(path)
    study.set_worker(name)
    done = 0
    while True:
        trials = study.ask()
        if not trials:
            break
        (t,) = trials
        study.heartbeat()
        time.sleep(0.05)  # the experiment
        study.tell(t, hartmann3(t.x))
        done += 1
    print(f"{name}: {done} trials")


if __name__ == "__main__":
    path = os.path.join(tempfile.mkdtemp(prefix="varbo-workers-"), "h3.db")
    varbo.Study.create(path, {"task": {"type": "hartmann3"}, "budget": 30, "seed": 1, "algorithm": {"type": "bo"}})
    ctx = mp.get_context("spawn")
    procs = [ctx.Process(target=worker, args=(path, f"worker-{i}")) for i in range(2)]
    for p in procs:
        p.start()
    for p in procs:
        p.join()
    study = varbo.Study.open(path)
    best = study.best()
    workers = {t.worker for t in study.trials(as_frame=False)}
    print(f"best {best.cost:.5f} (f* = -3.86278) at {best.params}; trials by {sorted(workers)}")
