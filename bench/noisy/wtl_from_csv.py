#!/usr/bin/env python3
"""Win/tie/loss of every algorithm of a bench_noisy results.csv against reference algorithms.

bench_noisy prints W/T/L only for its fixed pairs (vhgp vs gp, ... vs random / cma_es); this script compares every
algorithm of the CSV (including --add-algorithm ones) with each reference, on regret_recommended over the
(problem, seed) pairs, with bench_noisy's tie rule |a - b| <= max(1e-9, 1e-3 max(|a|, |b|)). Printed per reference:
heteroscedastic / homoscedastic totals, W/T/L by noise model and level, and by function; then the homoscedastic
(additive) medians of every algorithm with the ratio to the first reference, how many are within 2x of it, and the
median seconds per study.

    python3 bench/noisy/wtl_from_csv.py OUT/results.csv gp [vhgp ...]
"""
import collections
import csv
import statistics
import sys


def compare(a, b):
    if abs(a - b) <= max(1e-9, 1e-3 * max(abs(a), abs(b))):
        return 0
    return 1 if a < b else -1


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    rows = list(csv.DictReader(open(sys.argv[1])))
    refs = sys.argv[2:]
    regret = collections.defaultdict(dict)  # (problem, seed) -> algorithm -> regret
    seconds = collections.defaultdict(list)
    meta = {}
    for r in rows:
        if r.get("error"):
            print(f"error: {r['problem']} {r['algorithm']} s{r['seed']}: {r['error'][:100]}")
            continue
        regret[(r["problem"], r["seed"])][r["algorithm"]] = float(r["regret_recommended"])
        seconds[r["algorithm"]].append(float(r["seconds"]))
        meta[r["problem"]] = {"group": r["group"], "noise": r["noise"], "level": r["level"], "function": r["function"]}
    algorithms = sorted(seconds)

    def wtl(a, b, keep):
        w = t = l = 0
        for (p, _), d in regret.items():
            if keep(meta[p]) and a in d and b in d:
                c = compare(d[a], d[b])
                w += c == 1
                t += c == 0
                l += c == -1
        return w, t, l

    def fmt(x, pct=True):
        w, t, l = x
        n = w + t + l
        if n == 0:
            return "-"
        return f"{w}/{t}/{l} ({100 * w / n:.0f} %)" if pct else f"{w}/{t}/{l}"

    noises = sorted({(m["noise"], m["level"]) for m in meta.values()})
    functions = sorted({m["function"] for m in meta.values()})
    for ref in refs:
        print(f"\n| A vs {ref} | heteroscedastic | homoscedastic | "
              + " | ".join(f"{n} {lv}" for n, lv in noises) + " | "
              + " | ".join(f"{f} het / hom" for f in functions) + " |")
        print("|---" * (3 + len(noises) + len(functions)) + "|")
        for a in algorithms:
            if a == ref:
                continue
            cells = [fmt(wtl(a, ref, lambda m: m["group"] == "heteroscedastic")),
                     fmt(wtl(a, ref, lambda m: m["group"] == "homoscedastic"))]
            cells += [fmt(wtl(a, ref, lambda m, n=n, lv=lv: (m["noise"], m["level"]) == (n, lv)), False)
                      for n, lv in noises]
            cells += [fmt(wtl(a, ref, lambda m, f=f: m["function"] == f and m["group"] == "heteroscedastic"), False)
                      + " / " + fmt(wtl(a, ref, lambda m, f=f: m["function"] == f and m["group"] == "homoscedastic"),
                                    False) for f in functions]
            print(f"| {a} | " + " | ".join(cells) + " |")

    ref = refs[0]
    homo = sorted(p for p, m in meta.items() if m["group"] == "homoscedastic")
    if homo:
        print(f"\nhomoscedastic medians (ratio to {ref})\n\n| problem | " + " | ".join(algorithms) + " |")
        print("|---" * (1 + len(algorithms)) + "|")
        within = collections.Counter()
        for p in homo:
            med = {a: statistics.median([d[a] for (q, _), d in regret.items() if q == p and a in d]) for a in algorithms}
            cells = []
            for a in algorithms:
                ratio = med[a] / med[ref] if med[ref] > 0 else float("inf")
                within[a] += ratio <= 2
                cells.append(f"{med[a]:.2g} ({ratio:.1f}x)")
            print(f"| {p} | " + " | ".join(cells) + " |")
        print(f"\nwithin 2x of {ref}'s median: " + ", ".join(f"{a} {within[a]} of {len(homo)}" for a in algorithms))
    print("\nmedian seconds per study: " + ", ".join(
        f"{a} {statistics.median(seconds[a]):.2f} ({len(seconds[a])} studies)" for a in algorithms))


if __name__ == "__main__":
    main()
