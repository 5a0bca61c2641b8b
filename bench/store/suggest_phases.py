#!/usr/bin/env python3
# Where a `varbo suggest` process's CPU goes (docs/studies.md, "Cost of varbo suggest"): runs `varbo -v suggest` on
# fresh copies of a stored study and reads the process CPU time its --verbose log gives after each step of opening
# the study and asking it (std::clock: all threads) and the CPU of each plugin library it loads; prints the median
# of each step's increment over the runs, and the median of the whole process's CPU (its rusage, so the exit is in).
#   python3 bench/store/suggest_phases.py build/bin/varbo STUDY.db [RUNS]
#   python3 bench/store/suggest_phases.py build/bin/varbo 'postgresql://...&study=NAME' [RUNS]
# A PostgreSQL study (a Hartmann-6 study from make_study.py) is not copied: each run's trial is observed with its
# Hartmann-6 cost (`varbo observe`, not counted), so every suggest finds the study as a serial run left it.
import json, os, re, resource, shutil, statistics, subprocess, sys, tempfile

varbo, db = sys.argv[1], sys.argv[2]
runs = int(sys.argv[3]) if len(sys.argv) > 3 else 11
scratch = tempfile.mkdtemp(prefix="varbo_suggest_phases_")
copy = os.path.join(scratch, "study.db")
step_re = re.compile(r"\] (?:study|suggest): (.*): process CPU ([0-9.]+) ms")
plugin_re = re.compile(r"plugin '([^']+)' loaded from .*: ([0-9.]+) ms CPU")
steps, plugins, total = {}, {}, []
url = db.startswith(("postgresql://", "postgres://"))
if url:
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from make_study import hartmann6
for _ in range(runs):
    if not url:
        shutil.copy(db, copy)
        for s in ("-wal", "-shm"):
            if os.path.exists(copy + s):
                os.remove(copy + s)
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    done = subprocess.run([varbo, "-v", "suggest", db if url else copy, "--json"], stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, text=True, check=True)
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    err = done.stderr
    total.append(1e3 * (r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime))
    if url:
        t = json.loads(done.stdout)[0]
        subprocess.run([varbo, "-q", "observe", db, str(t["id"]), repr(hartmann6(t["theta"]))], check=True,
                       stdout=subprocess.DEVNULL)
    last = 0.0
    for line in err.splitlines():
        if m := step_re.search(line):
            steps.setdefault(m.group(1), []).append(float(m.group(2)) - last)
            last = float(m.group(2))
        elif m := plugin_re.search(line):
            plugins.setdefault(m.group(1), []).append(float(m.group(2)))
shutil.rmtree(scratch)
print(f"{db if url else os.path.basename(db)}: {runs} runs, load {os.getloadavg()[0]:.1f}; medians, ms CPU")
print("| step | CPU ms |\n|---|---|")
for name, v in steps.items():
    print(f"| {name} | {statistics.median(v):.2f} |")
print(f"| whole process (rusage) | {statistics.median(total):.2f} |")
print("\n| plugin library (within the configuration step) | CPU ms |\n|---|---|")
for name, v in plugins.items():
    print(f"| {name} | {statistics.median(v):.2f} |")
print(f"| all plugins | {sum(statistics.median(v) for v in plugins.values()):.2f} |")
