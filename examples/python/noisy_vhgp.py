"""A noisy objective with the heteroscedastic `vhgp` surrogate, then risk after learning (Kuindersma 2013).

Two minima of equal expected cost 0.1 at θ = 0.25 and 0.75; the noise grows to the right (std 0.03 vs 0.13 there).
This script evaluates the cost itself (ask/tell); the study's task, two_minima_1d, only gives the domain [0, 1].
The VHGP learns where the cost is noisy, so `select` picks, without a new trial, a risk-averse point (κ > 0: the quiet
minimum) and a risk-seeking one (κ < 0: the noisy one).
Run: PYTHONPATH=build/python /usr/bin/python3 examples/python/noisy_vhgp.py
"""
import math
import tempfile

import numpy as np

import varbo

rng = np.random.default_rng(1)


def noisy_cost(theta):
    mean = 0.5 + 0.4 * math.cos(4 * math.pi * theta)
    return mean + (0.02 + 0.2 * theta**2) * rng.standard_normal()


config = {
    "task": {"type": "two_minima_1d"},
    "budget": 30,
    "seed": 1,
    "algorithm": {
        "type": "bo",
        "initial_design": {"type": "uniform"},
        "initial_points": 10,
        "surrogate": {"type": "vhgp", "noise_model": "heteroscedastic", "restarts": 8, "jitter": 1e-6,
                      "prior_mu0": [-2.302585, 2.0], "prior_signal_std_g": [2.0, 0.5]},
        "acquisition": {"type": "ei", "xi": 1.0},
        "epsilon": 0.25,
        "region": {"type": "box"},
    },
}
study = varbo.Study.create(tempfile.mkdtemp(prefix="varbo-noisy-") + "/noisy.db", config)
while trials := study.ask():
    study.tell(trials[0], noisy_cost(trials[0].params["theta"]))

for sel in study.select([1.5, -1.5]):
    side = "risk-averse " if sel.kappa > 0 else "risk-seeking"
    print(f"κ = {sel.kappa:+.1f} ({side}): θ = {sel.params['theta']:.3f}, E[y] = {sel.mean:.3f}, sd = {sel.std:.3f}")
print("study file:", study.location)
