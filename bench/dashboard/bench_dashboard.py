#!/usr/bin/env python3
"""Speed of `varbo dashboard` (docs/dashboard.md, issue 17 targets); prints medians.

 1. history + table of a 1,000-trial study (random search on Branin): the API calls the page makes on load
    (summary, trials, history), and the page itself in headless chromium until its table holds every trial
    and its history every point (target < 1 s);
 2. a κ-slider move on a 200-trial VHGP study (observed points of a noisy Branin): /api/select latency after the
    model is cached (target < 300 ms), and the one-off fit;
 3. the server's overhead on a running study: wall time of `varbo run` (bo, GP, Branin) alone and with a
    dashboard polled as the page polls it (every 1.5 s; model, κ and slices on each new trial) (target < 5 %).

usage: nice -n 15 python3 bench/dashboard/bench_dashboard.py build/bin/varbo [WORK_DIR] [--reps N]"""
import json
import math
import os
import random
import resource
import shutil
import statistics
import subprocess
import sys
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "tests", "dashboard"))
from cdp_pipe import Chromium  # noqa: E402
from dashboard_fixture import Dashboard, run  # noqa: E402


def branin(x, y):
    b, c, t = 5.1 / (4 * math.pi ** 2), 5 / math.pi, 1 / (8 * math.pi)
    return (y - b * x * x + c * x - 6) ** 2 + 10 * (1 - t) * math.cos(x) + 10


def config(path, algorithm, budget, output, surrogate=None):
    alg = f"algorithm:\n  type: {algorithm}\n" + (f"  surrogate: {surrogate}\n" if surrogate else "")
    with open(path, "w") as f:
        f.write(f"task: {{type: branin}}\nbudget: {budget}\nseed: 1\noutput: {output}\n{alg}")
    return path


def timed(fn):
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


def bench_table(varbo, work, reps):
    folder = os.path.join(work, "random1000")
    run([varbo, "run", config(os.path.join(work, "r.yaml"), "random", 1000, folder), "--no-progress"])
    with Dashboard(varbo, folder) as d:
        api = [timed(lambda: [d.get(p) for p in ("/api/summary", "/api/trials?since=-1", "/api/history")])
               for _ in range(reps)]
        page = []
        with Chromium() as b:
            for _ in range(min(reps, 5)):
                b.open(d.url + "/")
                end = time.monotonic() + 30
                while time.monotonic() < end:
                    r = b.eval("""(() => { const n = document.querySelectorAll('#trials-body tr').length,
                                   p = document.querySelectorAll('#history .trial-point').length;
                                   return n === 1000 && p === 1000 ? window.dashboard.renderedAt : null; })()""")
                    if r:
                        page.append(r / 1000)
                        break
                    time.sleep(0.02)
    return api, page


def bench_kappa(varbo, work, reps):
    study = os.path.join(work, "vhgp200.db")
    if os.path.exists(study):
        os.remove(study)
    run([varbo, "study", "create", study, config(os.path.join(work, "v.yaml"), "bo", 200, work, "vhgp")])
    rng = random.Random(5)
    for _ in range(200):  # noise growing with x: what VHGP models
        x, y = rng.uniform(-5, 10), rng.uniform(0, 15)
        cost = branin(x, y) + rng.gauss(0, 1 + 2 * (x + 5) / 15)
        run([varbo, "observe", study, "new", repr(cost), "--theta", f"{x!r},{y!r}"])
    with Dashboard(varbo, study) as d:
        fit = timed(lambda: d.get("/api/model"))
        kappas = [round(-3 + 0.4 * i, 1) for i in range(16)]
        lat = []
        for r in range(reps):
            for k in kappas:
                t = time.perf_counter()
                status, body, _ = d.get(f"/api/select?kappa={k}")
                lat.append(time.perf_counter() - t)
                assert status == 200 and body["selection"]["ok"], body
    return fit, lat


def poll_like_the_page(d, stop):
    """What the page asks (dashboard_page.html, poll()): every 1.5 s, the model views at most every 5 s."""
    last, since, model_at = -1, -1, -1e9
    while not stop.is_set():
        _, s, _ = d.get("/api/summary")
        _, t, _ = d.get(f"/api/trials?since={since}")
        if t["trials"]:
            since = max(x["id"] for x in t["trials"])
            d.get("/api/history")
        if s["counts"]["complete"] != last and s["counts"]["complete"] >= 2 and time.monotonic() - model_at >= 5:
            last, model_at = s["counts"]["complete"], time.monotonic()
            x, y = s["names"][:2]
            for path in ("/api/model", "/api/select?kappa=0", "/api/slices?n=60", f"/api/grid?x={x}&y={y}"):
                assert d.get(path)[0] == 200, path
        stop.wait(1.5)


def iteration_seconds(varbo, study, skip):
    """Mean time per finished trial after the first `skip` (the BO iterations; export gives milliseconds)."""
    rows = run([varbo, "export", study, "--csv"]).stdout.splitlines()
    head = rows[0].split(",")
    col = head.index("finished_at")
    t = sorted(float(r.split(",")[col]) for r in rows[1:])[skip:]
    return (t[-1] - t[0]) / (len(t) - 1)


def bench_overhead(varbo, work, reps, budget=60):
    """The study is created first, the dashboard (when used) attached and polled, then `varbo run --study` fills it."""
    alone, served, cpu_share = [], [], []
    for r in range(reps):
        for with_dashboard in (False, True) if r % 2 == 0 else (True, False):
            folder = os.path.join(work, f"bo{r}{int(with_dashboard)}")
            shutil.rmtree(folder, ignore_errors=True)
            os.makedirs(folder)
            cfg = config(os.path.join(work, "b.yaml"), "bo", budget, folder, "gp")
            study = os.path.join(folder, "s.db")
            run([varbo, "study", "create", study, cfg])
            d, stop, th = None, threading.Event(), None
            if with_dashboard:
                d = Dashboard(varbo, study)
                th = threading.Thread(target=poll_like_the_page, args=(d, stop))
                th.start()
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            run([varbo, "run", cfg, "--study", study, "--no-progress"])
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            if d:
                stop.set()
                th.join()
                # CPU the server spent (all of it, start-up included) against the CPU of the run it watched: the
                # overhead on a machine with no idle core, free of the wall-time noise of a shared machine.
                with open(f"/proc/{d.proc.pid}/stat") as f:
                    fields = f.read().rsplit(")", 1)[1].split()
                server_cpu = (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
                run_cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
                cpu_share.append(server_cpu / run_cpu)
                d.close()
            (served if with_dashboard else alone).append(iteration_seconds(varbo, study, 10))
    return alone, served, cpu_share


def main():
    varbo = sys.argv[1]
    work = sys.argv[2] if len(sys.argv) > 2 and not sys.argv[2].startswith("--") else "/tmp/varbo-bench-dashboard"
    reps = int(sys.argv[sys.argv.index("--reps") + 1]) if "--reps" in sys.argv else 5
    os.makedirs(work, exist_ok=True)
    api, page = bench_table(varbo, work, reps)
    print(f"1,000-trial study: API summary+trials+history median {statistics.median(api) * 1e3:.0f} ms "
          f"(n={len(api)}); page shows table and history after {statistics.median(page) * 1e3:.0f} ms "
          f"(median of {len(page)} loads; target < 1000 ms)")
    fit, lat = bench_kappa(varbo, work, reps)
    print(f"200-trial VHGP study: first model fit {fit * 1e3:.0f} ms; kappa select median "
          f"{statistics.median(lat) * 1e3:.0f} ms, max {max(lat) * 1e3:.0f} ms (n={len(lat)}; target < 300 ms)")
    alone, served, cpu = bench_overhead(varbo, work, reps)
    a, s = statistics.median(alone), statistics.median(served)
    print(f"bo/GP on Branin, 60 trials: {a * 1e3:.0f} ms per iteration alone, {s * 1e3:.0f} ms with a polled "
          f"dashboard (medians of {len(alone)} runs each): ratio {s / a:.3f} (target < 1.05); the server's CPU time "
          f"is {statistics.median(cpu) * 100:.1f} % of the run's (median; max {max(cpu) * 100:.1f} %)")


if __name__ == "__main__":
    main()
