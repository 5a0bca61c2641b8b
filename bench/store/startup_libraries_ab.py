#!/usr/bin/env python3
# `varbo suggest` with the libraries of before the on-demand split (docs/studies.md, "Cost of varbo suggest"):
# the same build run with libpqxx and cpp-httplib preloaded (they bring libpq, OpenSSL, Kerberos, LDAP, brotli, ...)
# against the build as it is, interleaved, each run on a fresh copy of one study. Medians of wall time and of the
# child's CPU (user + system).
#   python3 bench/store/startup_libraries_ab.py build/bin/varbo STUDY.db [RUNS]
import os, resource, shutil, statistics, subprocess, sys, time
varbo, db = sys.argv[1], sys.argv[2]
n = int(sys.argv[3]) if len(sys.argv) > 3 else 15
pre = "/lib/x86_64-linux-gnu/libpqxx-6.4.so /lib/x86_64-linux-gnu/libcpp-httplib.so.0.11"
res = {"before (libpq + httplib loaded)": [], "after (loaded on demand)": []}
for i in range(n):
    for name in res:
        shutil.copy(db, "/tmp/varbo_startup_ab.db")
        for s in ("-wal", "-shm"):
            if os.path.exists("/tmp/varbo_startup_ab.db" + s): os.remove("/tmp/varbo_startup_ab.db" + s)
        env = dict(os.environ)
        if name.startswith("before"): env["LD_PRELOAD"] = pre
        r0 = resource.getrusage(resource.RUSAGE_CHILDREN); t0 = time.monotonic()
        subprocess.run([varbo, "-q", "suggest", "/tmp/varbo_startup_ab.db"], env=env, stdout=subprocess.DEVNULL, check=True)
        t = time.monotonic() - t0; r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        res[name].append((t, r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime))
print(f"load {os.getloadavg()[0]:.1f}, {n} interleaved runs each")
for name, v in res.items():
    print(f"{name}: wall {statistics.median(x[0] for x in v)*1e3:.1f} ms, CPU {statistics.median(x[1] for x in v)*1e3:.1f} ms")
