#!/usr/bin/env python3
# q parallel workers (docs/studies.md, "How close parallel suggestions are"): rounds of Study.ask(q), then every
# result told; per algorithm the median regret of Study.recommendation() and of the best observed cost over seeds
# 1..SEEDS, and the median nearest-neighbour distance within a batch (inf-norm, unit cube).
#   PYTHONPATH=build/python /usr/bin/python3 bench/store/batch_quality.py hartmann6 8 80 5 \
#     '{"kb": {"type": "bo"}, "clm": {"type": "bo", "batch_strategy": "constant_liar_min"}}'
import varbo, tempfile, numpy as np, math, sys, json, statistics
def branin(p):
    x, y = p[0], p[1]
    return (y - 5.1/(4*math.pi**2)*x*x + 5/math.pi*x - 6)**2 + 10*(1-1/(8*math.pi))*math.cos(x) + 10
A6 = np.array([[10,3,17,3.5,1.7,8],[0.05,10,17,0.1,8,14],[3,3.5,1.7,10,17,8],[17,8,0.05,10,0.1,14]])
P6 = 1e-4*np.array([[1312,1696,5569,124,8283,5886],[2329,4135,8307,3736,1004,9991],[2348,1451,3522,2883,3047,6650],[4047,8828,8732,5743,1091,381]])
C = np.array([1,1.2,3,3.2])
def h6(p): x=np.array(p); return float(-np.sum(C*np.exp(-np.sum(A6*(x-P6)**2,axis=1))))
probs = {"branin": (branin, [(-5,10),(0,15)], 0.397887), "hartmann6": (h6, [(0,1)]*6, -3.32237)}
def run(prob, alg, q, seed, budget):
    f, b, fstar = probs[prob]
    d = tempfile.mkdtemp()
    params = [{"name": f"x{i}", "type": "real", "low": lo, "high": hi} for i,(lo,hi) in enumerate(b)]
    s = varbo.Study.create(d + "/s.db", {"parameters": params, "budget": budget, "seed": seed, "algorithm": alg})
    nn = []
    while True:
        batch = s.ask(q)
        if not batch: break
        xs = np.array([t.x_unit for t in batch])
        if len(xs) > 1:
            D = np.abs(xs[:,None]-xs[None]).max(-1) + 9*np.eye(len(xs)); nn.append(float(np.median(D.min(1))))
        for t in batch: s.tell(t, f([t.params[p["name"]] for p in params]))
    r = s.recommendation()
    th = r.params if hasattr(r, "params") else r
    rec = f([th[p["name"]] for p in params]) - fstar
    best = min(t.cost for t in s.trials() if t.cost is not None) - fstar
    return rec, best, statistics.median(nn) if nn else float("nan")
if __name__ == "__main__":
    prob, q, budget = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    seeds = range(1, int(sys.argv[4]) + 1)
    for name, alg in json.loads(sys.argv[5]).items():
        res = [run(prob, alg, q, s, budget) for s in seeds]
        print(prob, f"q={q}", name, "median rec regret %.3g" % statistics.median(r[0] for r in res),
              "best %.3g" % statistics.median(r[1] for r in res), "median NN %.3g" % statistics.median(r[2] for r in res),
              "recs", " ".join("%.2g" % r[0] for r in res), flush=True)
