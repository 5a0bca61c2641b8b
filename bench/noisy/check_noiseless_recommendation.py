#!/usr/bin/env python3
"""Issue 10's check "on the noiseless problems the recommended θ is never worse than the best observed θ by more
than the fitted noise level", over many runs of the plain `bo` with the gp and the vhgp surrogate.

For every (surrogate, problem, instance, seed) it runs `varbo run` on the `noisy` task with `noise: none`, reads
summary.json's regret_recommended and regret_best_observed (both noise-free) and the last fitted model's noise level
from model.yaml (gp: noise_std; vhgp: exp(mu0 / 2), its noise sd where σ_g is small), and counts the runs where
regret_recommended − regret_best_observed exceeds that noise level.

  python3 bench/noisy/check_noiseless_recommendation.py build/bin/varbo OUT_DIR [--seeds 5] [--jobs 2]
"""
import argparse, concurrent.futures as cf, json, math, os, re, subprocess, sys

PROBLEMS = [  # (function, dim, budget): budgets of issue 10 (50 at d = 2, 100 at d = 5 and 6)
    ("sphere", 2, 50), ("rosenbrock", 2, 50), ("ellipsoid", 2, 50), ("rastrigin", 2, 50), ("branin", 2, 50),
    ("sphere", 5, 100), ("hartmann6", 6, 100)]
SURROGATES = ["gp", "vhgp"]


def last_noise(model_yaml, surrogate):
    text = open(model_yaml).read()
    if surrogate == "gp":
        vals = re.findall(r'"noise_std": ([0-9.eE+-]+)', text)
        return float(vals[-1]) if vals else float("nan")
    vals = re.findall(r'"mu0": ([0-9.eE+-]+)', text)
    return math.exp(float(vals[-1]) / 2) if vals else float("nan")


def one(args, surrogate, function, dim, budget, instance, seed):
    name = f"{surrogate}-{function}{dim}-i{instance}-s{seed}"
    out = os.path.join(args.out, name)
    dim_key = "" if function in ("branin", "hartmann6") else f", dim: {dim}"
    cfg = (f"task: {{type: noisy, function: {function}{dim_key}, instance: {instance}, noise: none}}\n"
           f"budget: {budget}\nseed: {seed}\nalgorithm: {{type: bo, surrogate: {{type: {surrogate}}}}}\n")
    path = out + ".yaml"
    open(path, "w").write(cfg)
    r = subprocess.run(["nice", "-n", "15", args.varbo, "run", path, "-o", out, "--overwrite", "--threads", "1"],
                       capture_output=True, text=True)
    if r.returncode != 0:
        return name, None, r.stderr.strip()[-300:]
    s = json.load(open(os.path.join(out, "summary.json")))
    gap = s["regret_recommended"] - s["regret_best_observed"]
    return name, (gap, last_noise(os.path.join(out, "model.yaml"), surrogate), s["regret_recommended"],
                  s["regret_best_observed"]), ""


def main():
    p = argparse.ArgumentParser()
    p.add_argument("varbo"); p.add_argument("out")
    p.add_argument("--seeds", type=int, default=5); p.add_argument("--instances", type=int, default=3)
    p.add_argument("--jobs", type=int, default=2)
    args = p.parse_args()
    os.makedirs(args.out, exist_ok=True)
    jobs = [(s, f, d, b, i, seed) for s in SURROGATES for (f, d, b) in PROBLEMS
            for i in range(1, args.instances + 1) for seed in range(1, args.seeds + 1)]
    results = {}
    with cf.ThreadPoolExecutor(args.jobs) as ex:
        for name, res, err in ex.map(lambda j: one(args, *j), jobs):
            results[name] = (res, err)
    worse = {s: [] for s in SURROGATES}
    runs = {s: 0 for s in SURROGATES}
    positive = {s: 0 for s in SURROGATES}
    errors = []
    for name, (res, err) in sorted(results.items()):
        s = name.split("-")[0]
        if res is None:
            errors.append((name, err)); continue
        runs[s] += 1
        gap, noise, rec, best = res
        if gap > 0: positive[s] += 1
        if not (gap <= noise):
            worse[s].append((name, gap, noise, rec, best))
    for s in SURROGATES:
        print(f"{s}: {runs[s]} runs; recommended worse than the best observed in {positive[s]}; "
              f"by more than the fitted noise sd in {len(worse[s])}")
        for w in worse[s]:
            print("   %s: gap %.3g > noise sd %.3g (recommended %.3g, best observed %.3g)" % w)
    for name, err in errors:
        print(f"ERROR {name}: {err}")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
