"""Shared fixtures of the Python package's tests (run by ctest as `python` and `python_long`)."""
import json
import math
import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(autouse=True, scope="session")
def _temporary_folders_under_pytest(tmp_path_factory):
    """minimize() without output= writes its run into a new temporary folder, which it keeps (the user's trials):
    the suite's calls go under pytest's own temporary root (it keeps the last three sessions), not into /tmp."""
    import tempfile
    before = tempfile.tempdir
    tempfile.tempdir = str(tmp_path_factory.mktemp("tempdir"))
    yield
    tempfile.tempdir = before


def varbo_bin() -> str:
    path = os.environ.get("VARBO_BIN") or str(ROOT / "build" / "bin" / "varbo")
    if not os.path.exists(path):
        pytest.skip(f"the varbo executable is not built ({path})")
    return path


def run_cli(*args, check=True, input=None):
    """Runs `varbo ARGS`; returns the CompletedProcess (text)."""
    r = subprocess.run([varbo_bin(), *map(str, args)], capture_output=True, text=True, input=input)
    if check and r.returncode != 0:
        raise AssertionError(f"varbo {' '.join(map(str, args))} exited {r.returncode}:\n{r.stderr}")
    return r


def branin(p):
    """Branin-Hoo written as tasks/benchmarks/benchmark_functions.cpp computes it (same operation order, so the
    same doubles as the C++ task)."""
    x0, x1 = p["x1"], p["x2"]
    pi = math.pi
    b, c, r, s, t = 5.1 / (4 * pi * pi), 5 / pi, 6, 10, 1 / (8 * pi)
    q = x1 - b * x0 * x0 + c * x0 - r
    return q * q + s * (1 - t) * math.cos(x0) + s


BRANIN_SPACE = {"x1": (-5.0, 10.0), "x2": (0.0, 15.0)}


def read_trials_csv(path):
    import csv
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def pytest_configure(config):
    config.addinivalue_line("markers", "long: slow tests (ctest label long)")
