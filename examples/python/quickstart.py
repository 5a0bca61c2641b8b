"""Quick start: Branin with varbo's default Bayesian optimization.
Run: PYTHONPATH=build/python /usr/bin/python3 examples/python/quickstart.py"""
import math

import varbo


def branin(p):
    x, y = p["x"], p["y"]
    return (y - 5.1 / (4 * math.pi**2) * x**2 + 5 / math.pi * x - 6) ** 2 + 10 * (1 - 1 / (8 * math.pi)) * math.cos(x) + 10


res = varbo.minimize(branin, {"x": (-5, 10), "y": (0, 15)}, budget=40, seed=1)
print(f"best {res.fun:.6f} at {res.params}; recommended {res.recommended_params}; run folder {res.output}")
