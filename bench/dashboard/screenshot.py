#!/usr/bin/env python3
"""docs/img/dashboard.png: the dashboard on examples/quickstart.yaml (GP-EI on Branin, 30 trials), κ = 1.5.

usage: python3 bench/dashboard/screenshot.py build/bin/varbo [OUT.png]"""
import os
import shutil
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..", "..")
sys.path.insert(0, os.path.join(ROOT, "tests", "dashboard"))
from cdp_pipe import Chromium  # noqa: E402
from dashboard_fixture import Dashboard, run, wait_for  # noqa: E402

varbo = sys.argv[1]
out = sys.argv[2] if len(sys.argv) > 2 else os.path.join(ROOT, "docs", "img", "dashboard.png")
work = tempfile.mkdtemp(prefix="varbo-shot-")
folder = os.path.join(work, "quickstart")
run([varbo, "run", os.path.join(ROOT, "examples", "quickstart.yaml"), "-o", folder, "--no-progress"])
with Dashboard(varbo, folder) as d, Chromium(width=1280, height=900) as b:
    b.open(d.url + "/")
    wait_for(lambda: b.eval("document.querySelectorAll('#trials-body tr').length") == 30, 20, "the table")
    b.eval("(() => { const s = document.getElementById('kappa'); s.value = '1.5'; s.dispatchEvent(new Event('input')); })()")
    wait_for(lambda: b.eval("window.dashboard.selection && window.dashboard.selection.kappa === 1.5"), 20, "kappa")
    wait_for(lambda: b.eval("document.querySelectorAll('#grid svg').length") == 2, 20, "the maps")
    time.sleep(0.5)
    b.screenshot(out, scale=0.6, height=1750)
shutil.rmtree(work, ignore_errors=True)
print(out, os.path.getsize(out), "bytes")
