"""The Python layer's cost per ask/tell against one BO iteration (issue 16: ≤ 10 % at N = 50).

One Hartmann-6 study with the plain default `{type: bo}` (seed 1) is driven from Python with Study.ask() / tell().
For the iterations whose finished-trial count N lies in [N0 - 4, N0 + 4] it records the wall time of each Python
call and the time the C++ engine spent inside it (`_Study.engine_seconds`, measured around the varbo::Study call);
the layer's overhead is the difference (GIL release, locking, converting the trial to a dict and a Trial, parsing
arguments). Printed: medians of the BO iteration (engine ask + tell: model fit, acquisition, study store), of its fit +
acquisition part alone (the trial's fit_seconds + acquisition_seconds), of the overhead per ask + tell, and ratios.

    nice -n 15 env PYTHONPATH=build/python /usr/bin/python3 bench/python/bench_overhead.py [--n 50] [--threads 2]
"""
import argparse
import math
import statistics
import tempfile
import time

import varbo


def hartmann6(x):
    A = [[10, 3, 17, 3.5, 1.7, 8], [0.05, 10, 17, 0.1, 8, 14], [3, 3.5, 1.7, 10, 17, 8], [17, 8, 0.05, 10, 0.1, 14]]
    P = [[0.1312, 0.1696, 0.5569, 0.0124, 0.8283, 0.5886], [0.2329, 0.4135, 0.8307, 0.3736, 0.1004, 0.9991],
         [0.2348, 0.1451, 0.3522, 0.2883, 0.3047, 0.6650], [0.4047, 0.8828, 0.8732, 0.5743, 0.1091, 0.0381]]
    alpha = [1.0, 1.2, 3.0, 3.2]
    return -sum(a * math.exp(-sum(A[i][j] * (x[j] - P[i][j]) ** 2 for j in range(6))) for i, a in enumerate(alpha))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=50)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    cfg = {"task": {"type": "hartmann6"}, "budget": a.n + 5, "seed": a.seed, "threads": a.threads,
           "algorithm": {"type": "bo"}}
    study = varbo.Study.create(tempfile.mkdtemp(prefix="varbo-bench-") + "/h6.db", cfg)
    iteration, overhead, py_total, compute = [], [], [], []
    for n in range(a.n + 5):
        t0 = time.perf_counter()
        (trial,) = study.ask()
        t_ask = time.perf_counter() - t0
        e_ask = study._impl.engine_seconds
        cost = hartmann6(trial.x)
        t0 = time.perf_counter()
        study.tell(trial, cost)
        t_tell = time.perf_counter() - t0
        e_tell = study._impl.engine_seconds
        if abs(n - a.n) <= 4:
            iteration.append(e_ask + e_tell)
            overhead.append((t_ask - e_ask) + (t_tell - e_tell))
            py_total.append(t_ask + t_tell)
            compute.append(trial.fit_seconds + trial.acquisition_seconds)
    it, ov = statistics.median(iteration), statistics.median(overhead)
    print(f"Hartmann-6, plain default bo, seed {a.seed}, threads {a.threads}, N = {a.n} (median of {len(iteration)})")
    print(f"  BO iteration (engine ask + tell)     {it * 1e3:9.3f} ms")
    print(f"  Python call (ask + tell, wall)       {statistics.median(py_total) * 1e3:9.3f} ms")
    print(f"  Python layer overhead per ask + tell {ov * 1e6:9.1f} µs")
    cp = statistics.median(compute)
    print(f"  of which model fit + acquisition     {cp * 1e3:9.3f} ms   (the rest: the study store)")
    print(f"  overhead / iteration                 {100 * ov / it:9.2f} %   (target ≤ 10 %)")
    print(f"  overhead / (fit + acquisition)       {100 * ov / cp:9.2f} %")


if __name__ == "__main__":
    main()
