#!/usr/bin/env python3
# `varbo suggest` as a fresh process, two builds against each other (docs/studies.md, "Cost of varbo suggest"):
# interleaved runs, each on a fresh copy of one stored study (so every run suggests the same trial from the same
# state), medians of wall time and of the child's CPU (user + system). A build is a `varbo` executable; give an
# installed one (`cmake --install build --prefix DIR`: its libraries and plugins are found from $ORIGIN) for the
# "before" side. With one executable it times that build alone.
#   python3 bench/store/suggest_ab.py [--runs 11] VARBO_A [VARBO_B] -- STUDY.db [STUDY.db ...]
import os, resource, shutil, statistics, subprocess, sys, tempfile, time

args = sys.argv[1:]
runs = 11
if args[:1] == ["--runs"]:
    runs, args = int(args[1]), args[2:]
split = args.index("--")
builds, studies = args[:split], args[split + 1:]
scratch = tempfile.mkdtemp(prefix="varbo_suggest_ab_")
copy = os.path.join(scratch, "study.db")


def one(varbo, db):
    shutil.copy(db, copy)
    for s in ("-wal", "-shm"):
        if os.path.exists(copy + s):
            os.remove(copy + s)
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.monotonic()
    subprocess.run([varbo, "-q", "suggest", copy], stdout=subprocess.DEVNULL, check=True)
    t = time.monotonic() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return t, r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime


print(f"{runs} interleaved runs per build and study; load {os.getloadavg()[0]:.1f} at the start")
print("| study | build | wall ms (median) | CPU ms (median) | CPU ms (min) |\n|---|---|---|---|---|")
for db in studies:
    res = {b: [] for b in builds}
    for _ in range(runs):
        for b in builds:
            res[b].append(one(b, db))
    for b, v in res.items():
        cpu = [x[1] * 1e3 for x in v]
        print(f"| {os.path.basename(db)} | {b} | {statistics.median(x[0] for x in v) * 1e3:.1f} | "
              f"{statistics.median(cpu):.1f} | {min(cpu):.1f} |")
print(f"load {os.getloadavg()[0]:.1f} at the end")
shutil.rmtree(scratch)
