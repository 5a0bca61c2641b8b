"""Shared by the dashboard tests and bench/dashboard: a study whose parameter names, cost-component names and
failure messages are hostile (HTML, quotes, control characters), a `varbo dashboard` started on a free port, and
small HTTP helpers. Standard library only."""
import json
import os
import re
import subprocess
import sys
import textwrap
import time
import urllib.error
import urllib.request

# Parameter names that would run script or break markup if a page put them in as HTML.
HOSTILE_X = 'gain<img src=x onerror="window.pwned=1">'
HOSTILE_Y = "off'set\"&amp;</td>"
HOSTILE_COMPONENT = "<b>energy</b>\u00e9"
HOSTILE_ERROR = "<script>window.pwned=2</script> \"quoted\" & tab\there"

OBJECTIVE = textwrap.dedent(r'''
    # Branin with a named cost component; trial FAIL_TRIAL reports a hostile failure message.
    import json, math, os, sys, time
    q = json.loads(sys.stdin.readline())
    x, y = q["theta"]
    k = q["trial"]
    time.sleep(float(os.environ.get("OBJECTIVE_SLEEP", "0")))
    if k == int(os.environ.get("FAIL_TRIAL", "-1")):
        print(json.dumps({"error": os.environ["FAIL_MESSAGE"]}))
        sys.exit(0)
    b, c, t = 5.1 / (4 * math.pi ** 2), 5 / math.pi, 1 / (8 * math.pi)
    cost = (y - b * x * x + c * x - 6) ** 2 + 10 * (1 - t) * math.cos(x) + 10
    print(json.dumps({"cost": cost, "components": {os.environ["COMPONENT"]: 0.5 * cost}}))
''')


def yaml_quote(s):
    return json.dumps(s)  # a JSON string is a YAML double-quoted scalar


def write_study(folder, budget, surrogate="gp", algorithm="bo", initial_points=4, extra=""):
    """A study configuration over the external objective (`folder`/objective.py); returns its path."""
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, "objective.py"), "w") as f:
        f.write(OBJECTIVE)
    algo = (f"algorithm:\n  type: {algorithm}\n  initial_points: {initial_points}\n  surrogate: {surrogate}\n"
            if algorithm == "bo" else f"algorithm:\n  type: {algorithm}\n")
    cfg = textwrap.dedent(f"""\
        task:
          type: external
          command: {yaml_quote(sys.executable + ' ' + os.path.join(folder, 'objective.py'))}
          lower: [-5, 0]
          upper: [10, 15]
          names: [{yaml_quote(HOSTILE_X)}, {yaml_quote(HOSTILE_Y)}]
          timeout: 60
        budget: {budget}
        seed: 3
        output: {yaml_quote(os.path.join(folder, 'run'))}
        """) + algo + extra
    path = os.path.join(folder, "study.yaml")
    with open(path, "w") as f:
        f.write(cfg)
    return path


def objective_env(fail_trial=-1, sleep=0.0):
    env = dict(os.environ)
    env.update(FAIL_TRIAL=str(fail_trial), FAIL_MESSAGE=HOSTILE_ERROR, COMPONENT=HOSTILE_COMPONENT,
               OBJECTIVE_SLEEP=str(sleep))
    return env


def run(cmd, env=None, check=True):
    r = subprocess.run(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if check and r.returncode != 0:
        raise AssertionError(f"{' '.join(cmd)} exited {r.returncode}\nstdout:\n{r.stdout}\nstderr:\n{r.stderr}")
    return r


class Dashboard:
    """`varbo dashboard STUDY --port 0`, stopped on exit."""

    def __init__(self, varbo, study, extra=()):
        self.proc = subprocess.Popen([varbo, "dashboard", study, "--port", "0", *extra], stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True)
        line = self.proc.stdout.readline()
        m = re.search(r"http://127\.0\.0\.1:(\d+)/", line)
        if not m:
            self.proc.kill()
            raise AssertionError(f"dashboard did not start: {line!r} {self.proc.stderr.read()}")
        self.url = f"http://127.0.0.1:{m.group(1)}"

    def get(self, path):
        """(status, parsed JSON body, raw text)."""
        try:
            with urllib.request.urlopen(self.url + path, timeout=60) as r:
                raw = r.read().decode("utf-8")
                return r.status, json.loads(raw) if r.headers.get_content_type() == "application/json" else None, raw
        except urllib.error.HTTPError as e:
            raw = e.read().decode("utf-8")
            return e.code, json.loads(raw), raw

    def close(self):
        self.proc.terminate()
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def wait_for(predicate, timeout, what):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        v = predicate()
        if v:
            return v
        time.sleep(0.1)
    raise AssertionError(f"timed out after {timeout} s waiting for {what}")
