#!/usr/bin/env python3
# A Hartmann-6 study (plain default `{type: bo}`, seed 1, budget 1000) driven by `varbo suggest` / `varbo observe`
# processes to N finished trials, as an external worker would; for suggest_phases.py and suggest_ab.py
# (docs/studies.md, "Cost of varbo suggest"). An existing STUDY is continued by N more trials.
#   python3 bench/store/make_study.py build/bin/varbo STUDY.db N
import json, math, os, subprocess, sys, tempfile

A = [[10, 3, 17, 3.5, 1.7, 8], [0.05, 10, 17, 0.1, 8, 14], [3, 3.5, 1.7, 10, 17, 8], [17, 8, 0.05, 10, 0.1, 14]]
P = [[1312, 1696, 5569, 124, 8283, 5886], [2329, 4135, 8307, 3736, 1004, 9991],
     [2348, 1451, 3522, 2883, 3047, 6650], [4047, 8828, 8732, 5743, 1091, 381]]
ALPHA = [1.0, 1.2, 3.0, 3.2]


def hartmann6(x):
    return -sum(ALPHA[i] * math.exp(-sum(A[i][j] * (x[j] - P[i][j] * 1e-4) ** 2 for j in range(6))) for i in range(4))


if __name__ == "__main__":
    varbo, study, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
    if not os.path.exists(study):
        with tempfile.NamedTemporaryFile("w", suffix=".yaml", delete=False) as cfg:
            cfg.write("task: {type: hartmann6}\nbudget: 1000\nseed: 1\nalgorithm: {type: bo}\n")
        subprocess.run([varbo, "-q", "study", "create", study, cfg.name], check=True, stdout=subprocess.DEVNULL)
        os.remove(cfg.name)
    for _ in range(n):
        out = subprocess.run([varbo, "-q", "suggest", study, "--json"], check=True, capture_output=True, text=True).stdout
        t = json.loads(out)[0]
        subprocess.run([varbo, "-q", "observe", study, str(t["id"]), repr(hartmann6(t["theta"]))], check=True,
                       stdout=subprocess.DEVNULL)
