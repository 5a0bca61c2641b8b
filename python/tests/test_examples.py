"""The examples in examples/python run and print what they promise (long: full-size studies)."""
import os
import re
import subprocess
import sys

import pytest

from conftest import ROOT

pytestmark = pytest.mark.long


def run_example(name, *args):
    env = dict(os.environ)
    r = subprocess.run([sys.executable, str(ROOT / "examples" / "python" / name), *args], capture_output=True,
                       text=True, env=env, timeout=900)
    assert r.returncode == 0, r.stderr
    return r.stdout


def test_quickstart():
    out = run_example("quickstart.py")
    best = float(re.search(r"best ([0-9.]+)", out).group(1))
    assert best - 0.397887 < 1e-3


def test_noisy_vhgp_selects_both_minima():
    out = run_example("noisy_vhgp.py")
    averse = re.search(r"κ = \+1\.5 .*θ = ([0-9.]+), E\[y\] = (-?[0-9.]+), sd = ([0-9.]+)", out)
    seeking = re.search(r"κ = -1\.5 .*θ = ([0-9.]+), E\[y\] = (-?[0-9.]+), sd = ([0-9.]+)", out)
    # The risk-averse choice is the quieter point, the risk-seeking one the noisier (the learned noise).
    assert float(averse.group(3)) < float(seeking.group(3))


def test_two_workers_share_a_study():
    out = run_example("two_workers.py")
    assert "worker-0" in out and "worker-1" in out
    best = float(re.search(r"best (-?[0-9.]+)", out).group(1))
    assert best < -3.5
