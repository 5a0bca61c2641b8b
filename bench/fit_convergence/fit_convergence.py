#!/usr/bin/env python3
"""Fit convergence and cost of the default `ceres_lbfgs` stopping rule (issue 12, item 9).

usage: bench/fit_convergence/fit_convergence.py build/bin/varbo [REPS]

Fits (1) the default `vhgp` to the motorcycle data (mcycle.csv: Silverman 1985, as in R's MASS::mcycle; x = time
after impact in ms, y = head acceleration in g; N = 133) and (2) the default `gp` to 100 points of a smooth 6-D
function plus noise (generated here, Python's `random` with seed 2), with seeds 1..REPS, `--threads 1`, each with
the default optimizer and with `relative_gradient_tolerance: 1e300` (Ceres' relative function rule alone, the
rule before), runs interleaved. Prints median CPU seconds (user + system of the `varbo fit` process) and the gap
of the objective to the best one found by a tight optimizer (function tolerance 1e-12, 3000 iterations).
"""
import json, math, os, random, resource, statistics, subprocess, sys, tempfile

varbo = sys.argv[1]
reps = int(sys.argv[2]) if len(sys.argv) > 2 else 7
here = os.path.dirname(os.path.abspath(__file__))
work = tempfile.mkdtemp(prefix="fit_convergence_")

gp_data = os.path.join(work, "gp100d6.csv")
rng = random.Random(2)
with open(gp_data, "w") as f:
    f.write("x1,x2,x3,x4,x5,x6,y\n")
    for _ in range(100):
        x = [rng.random() for _ in range(6)]
        y = sum(math.sin(3 * (j + 1) * x[j]) / (j + 1) for j in range(6)) + rng.gauss(0, 0.1)
        f.write(",".join(f"{v:.6f}" for v in x) + f",{y:.6f}\n")


def fit(surrogate, data, optimizer, seed):
    yaml = os.path.join(work, "s.yaml")
    with open(yaml, "w") as f:
        f.write(f"type: {surrogate}\n" + (f"fit_optimizer: {optimizer}\n" if optimizer else ""))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    out = subprocess.run([varbo, "fit", "--surrogate", yaml, "--data", data, "--threads", "1", "--seed", str(seed)],
                         capture_output=True, text=True, check=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    return cpu, json.loads(out.stdout)["objective"]


cases = [("vhgp", os.path.join(here, "mcycle.csv"), "", "{type: ceres_lbfgs}"),
         ("gp", gp_data, "max_iterations: 100, ", "{type: ceres_lbfgs, max_iterations: 100}")]
for surrogate, data, extra, default in cases:
    old = "{type: ceres_lbfgs, " + extra + "relative_gradient_tolerance: 1.0e+300}"
    tight = "{type: ceres_lbfgs, function_tolerance: 1.0e-12, relative_gradient_tolerance: 1.0e-9, max_iterations: 3000}"
    best = max(fit(surrogate, data, tight, s)[1] for s in (1, 2))
    runs = {"function rule alone": old, "default": default}
    cpu = {k: [] for k in runs}
    gap = {k: [] for k in runs}
    for seed in range(1, reps + 1):
        for name, opt in runs.items():
            c, o = fit(surrogate, data, opt, seed)
            cpu[name].append(c)
            gap[name].append(max(best - o, 0.0))
    print(f"{surrogate} on {os.path.basename(data)} (best objective {best:.6f}, seeds 1-{reps}):")
    for name in runs:
        print(f"  {name:20s} CPU median {statistics.median(cpu[name]):.3f} s; objective gap median "
              f"{statistics.median(gap[name]):.2g}, max {max(gap[name]):.2g}; per seed "
              + " ".join(f"{g:.2g}" for g in gap[name]))
    print(f"  CPU ratio default / function rule alone: "
          f"{statistics.median(cpu['default']) / statistics.median(cpu['function rule alone']):.2f}")
