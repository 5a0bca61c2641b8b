"""VarboSampler vs Optuna's TPE through Optuna (issue 16): 100 trials, seeds 1–10, Branin and Hartmann-6; the
median [q1, q3] regret of the best value found (study.best_value − f*). Both samplers at their defaults
(VarboSampler: the plain `{type: bo}`; TPESampler(seed=s)).

    nice -n 15 env PYTHONPATH=build/python /usr/bin/python3 bench/python/optuna_compare.py [--seeds 10] [--trials 100]
"""
import argparse
import math
import statistics
import sys
import time

import numpy as np
import optuna

import varbo.optuna


def branin(x):
    pi = math.pi
    q = x[1] - 5.1 / (4 * pi * pi) * x[0] ** 2 + 5 / pi * x[0] - 6
    return q * q + 10 * (1 - 1 / (8 * pi)) * math.cos(x[0]) + 10


def hartmann6(x):
    A = [[10, 3, 17, 3.5, 1.7, 8], [0.05, 10, 17, 0.1, 8, 14], [3, 3.5, 1.7, 10, 17, 8], [17, 8, 0.05, 10, 0.1, 14]]
    P = [[0.1312, 0.1696, 0.5569, 0.0124, 0.8283, 0.5886], [0.2329, 0.4135, 0.8307, 0.3736, 0.1004, 0.9991],
         [0.2348, 0.1451, 0.3522, 0.2883, 0.3047, 0.6650], [0.4047, 0.8828, 0.8732, 0.5743, 0.1091, 0.0381]]
    alpha = [1.0, 1.2, 3.0, 3.2]
    return -sum(a * math.exp(-sum(A[i][j] * (x[j] - P[i][j]) ** 2 for j in range(6))) for i, a in enumerate(alpha))


PROBLEMS = {
    "Branin": (branin, [(-5.0, 10.0), (0.0, 15.0)], 10 / (8 * math.pi)),
    "Hartmann-6": (hartmann6, [(0.0, 1.0)] * 6, -3.32236801141551),
}


def run(problem, sampler, trials):
    f, bounds, fstar = PROBLEMS[problem]

    def objective(trial):
        return f([trial.suggest_float(f"x{i}", lo, hi) for i, (lo, hi) in enumerate(bounds)])

    study = optuna.create_study(sampler=sampler)
    study.optimize(objective, n_trials=trials)
    return study.best_value - fstar


def summary(v):
    q1, med, q3 = np.percentile(v, [25, 50, 75])
    return f"{med:.3g} [{q1:.3g}, {q3:.3g}]"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--trials", type=int, default=100)
    ap.add_argument("--problems", default="Branin,Hartmann-6")
    ap.add_argument("--threads", type=int, default=2)
    a = ap.parse_args()
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    seeds = range(1, a.seeds + 1)
    print(f"{a.trials} trials, seeds 1–{a.seeds}: regret of the best value, median [q1, q3]; wall s per run")
    print("| problem | VarboSampler | TPE | varbo s/run | TPE s/run |")
    print("|---|---|---|---|---|")
    for problem in a.problems.split(","):
        res = {"varbo": [], "tpe": []}
        secs = {"varbo": [], "tpe": []}
        for s in seeds:
            for name, make in (("varbo", lambda: varbo.optuna.VarboSampler(seed=s, threads=a.threads)),
                               ("tpe", lambda: optuna.samplers.TPESampler(seed=s))):
                t0 = time.perf_counter()
                res[name].append(run(problem, make(), a.trials))
                secs[name].append(time.perf_counter() - t0)
            print(f"  {problem} seed {s}: varbo {res['varbo'][-1]:.3g}, tpe {res['tpe'][-1]:.3g}", file=sys.stderr)
        print(f"| {problem} | {summary(res['varbo'])} | {summary(res['tpe'])} | "
              f"{statistics.median(secs['varbo']):.1f} | {statistics.median(secs['tpe']):.1f} |")


if __name__ == "__main__":
    main()
