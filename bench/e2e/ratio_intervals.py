#!/usr/bin/env python3
"""Ratio of median regrets (failing / failure-free run) with a 90 % paired-bootstrap interval, from bench_failures'
per-seed lines on stderr ("... seed N: failed a/b ... regret rec X vs Y, ...").

    python3 bench/e2e/ratio_intervals.py FAILING.err [FAILURE_FREE.err]

FAILING.err gives each seed's regret with failures (X); the failure-free regret (Y) comes from FAILURE_FREE.err, or
from FAILING.err itself when the run had the failure-free arm (without --with-failures-only). Runs made with
--with-failures-only of one task share the failure-free runs of that task (the same seeds and budget give the same
runs), so any full run of the task and budget serves as FAILURE_FREE.err.

The same method as bench_failures' "ratio of medians" column (session 39): 2,000 resamples of the seeds with
replacement, each seed's two runs kept together; only the random resamples differ (Python's generator here), which
moves the interval's ends by a few hundredths (held-out region 10: 0.21 [0.11, 0.63] there, [0.12, 0.61] here).
"""
import random
import re
import statistics
import sys

LINE = re.compile(r"seed (\d+): failed \d+/\d+ .*regret rec (\S+) vs (\S+),")


def per_seed(path, column):
    out = {}
    with open(path) as f:
        for line in f:
            m = LINE.search(line)
            if m:
                out[int(m.group(1))] = float(m.group(column))
    return out


def main():
    if len(sys.argv) not in (2, 3):
        sys.exit(__doc__)
    with_failures = per_seed(sys.argv[1], 2)
    without = per_seed(sys.argv[2] if len(sys.argv) == 3 else sys.argv[1], 3)
    seeds = sorted(set(with_failures) & set(without))
    if not seeds or any(v != v for v in without.values()):
        sys.exit("no failure-free regrets in the logs (a --with-failures-only run: name a full run as FAILURE_FREE.err)")
    rng = random.Random(1)
    ratios = []
    for _ in range(2000):
        pick = [rng.choice(seeds) for _ in seeds]
        ratios.append(statistics.median(with_failures[s] for s in pick) / statistics.median(without[s] for s in pick))
    ratios.sort()
    ratio = statistics.median(with_failures[s] for s in seeds) / statistics.median(without[s] for s in seeds)
    print(f"{len(seeds)} seeds: ratio of medians {ratio:.2g} [{ratios[100]:.2g}, {ratios[1899]:.2g}]")


if __name__ == "__main__":
    main()
