"""Browser test of `varbo dashboard` in Debian's headless chromium (DevTools protocol over a pipe): the page shows
a run's trials, follows the run as it continues while the page is open (history and table grow without a reload),
moving the κ slider shows the selection `varbo select --kappa K` prints, the RSSGD re-weighting shows its selections,
and hostile names stay text. Screenshots are
kept in WORK_DIR as test artefacts. Fails (never skips) when chromium is missing.

usage: test_dashboard_browser.py VARBO WORK_DIR"""
import json
import os
import shutil
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cdp_pipe import Chromium
from dashboard_fixture import HOSTILE_X, Dashboard, objective_env, run, wait_for, write_study

checks = 0


def check(cond, what):
    global checks
    checks += 1
    if not cond:
        raise AssertionError(what)


def page_counts(b):
    return b.eval("""!window.dashboard ? {rows: 0, points: 0, failed: 0, polls: 0, pending: -1} : ({rows: document.querySelectorAll('#trials-body tr').length,
                      points: document.querySelectorAll('#history .trial-point').length,
                      failed: document.querySelectorAll('#history .failed-mark').length,
                      polls: window.dashboard.polls,
                      pending: window.dashboard.summary ? window.dashboard.summary.counts.pending : -1})""")


def main():
    varbo, work = sys.argv[1], sys.argv[2]
    shutil.rmtree(work, ignore_errors=True)
    cfg = write_study(work, budget=6, initial_points=4)
    run([varbo, "run", cfg, "--no-progress"], env=objective_env(fail_trial=2))
    folder = os.path.join(work, "run")
    t0 = time.monotonic()
    with Dashboard(varbo, folder) as d, Chromium() as b:
        b.open(d.url + "/")
        c = wait_for(lambda: (lambda c: c if c["rows"] == 6 and c["points"] == 5 and c["failed"] == 1 else None)(page_counts(b)),
                     60, "the page to show the 6 trials of the run")
        check(True, "first trials shown")
        b.screenshot(os.path.join(work, "dashboard_initial.png"))

        b.eval("window.sameDocument = 1")  # gone if the page reloads
        # The run continues (4 more trials of 2 s each, longer than the page's 1.5 s poll, so one poll sees a trial
        # pending even on a loaded machine) while the page is open.
        cont = subprocess.Popen([varbo, "run", "--resume", folder, "--budget", "10", "--no-progress"],
                                env=objective_env(fail_trial=-1, sleep=2.0), stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True)
        seen, pending_rows = set(), []
        def grown():
            c = page_counts(b)
            seen.add(c["rows"])
            pending_rows.append(b.eval("document.querySelectorAll('#trials-body tr.pending').length"))
            return c if c["rows"] == 10 and c["points"] == 9 else None
        wait_for(grown, 90, "the page to show the continued run's trials")
        out, err = cont.communicate(timeout=60)
        check(cont.returncode == 0, f"continued run: exit {cont.returncode}: {err}")
        check(len([n for n in seen if 6 < n < 10]) >= 1, f"trials appeared one by one while the page was open: {sorted(seen)}")
        check(max(pending_rows) >= 1, "a pending trial was shown while it ran")
        check(b.eval("window.sameDocument") == 1, "no reload: the page appended the new trials itself")
        # A trial seen pending is updated once it finishes (the page asks from before its oldest pending trial).
        wait_for(lambda: b.eval("document.querySelectorAll('#trials-body tr.pending').length === 0 && "
                                "document.querySelectorAll('#trials-body tr.complete').length === 9"),
                 60, "every row complete or failed once the run is over")

        # Hostile names are text: no element was made from them, no script ran.
        check(b.eval("window.pwned === undefined"), "no script from the study ran")
        check(b.eval("document.querySelectorAll('img').length") == 0, "no element from a parameter name")
        heads = b.eval("[...document.querySelectorAll('#trials-head th')].map(e => e.textContent)")
        check(any(h.startswith(HOSTILE_X) for h in heads), f"the hostile name shown as text: {heads}")

        # The κ slider: each position shows the selection `varbo select` gives for that κ.
        b.eval("window.dashboard.kappaAsked = null")
        for kappa in ("2", "-1.5"):
            b.eval(f"""(() => {{ const s = document.getElementById('kappa'); s.value = '{kappa}';
                                 s.dispatchEvent(new Event('input')); }})()""")
            sel = wait_for(lambda: b.eval(f"""(() => {{ const s = window.dashboard.selection;
                                 return s && s.kappa === {kappa} && window.dashboard.lastComplete === 9 ? s : null; }})()"""),
                           60, f"the selection for kappa {kappa}")
            ref = json.loads(run([varbo, "select", folder, "--kappa", kappa, "--json"]).stdout)["selections"][0]
            check(sel == ref, f"kappa {kappa}: page {sel} vs varbo select {ref}")
            shown = b.eval("[...document.querySelectorAll('#selection .sel-value')].map(e => e.textContent)")
            check(shown[0] == str(float(kappa)).rstrip("0").rstrip(".") and len(shown) >= 5, f"selection table {shown}")
            b.screenshot(os.path.join(work, f"dashboard_kappa_{kappa}.png"))
        check(b.eval("document.querySelectorAll('#slices svg').length") == 2, "one slice per parameter")
        check(b.eval("document.querySelectorAll('#grid svg').length") == 2, "mean and s maps")
        b.eval("document.querySelector('#trials-head th:nth-child(%d)').click()" % (3 + 2 + 1))  # sort by cost
        costs = b.eval("[...document.querySelectorAll('#trials-body tr.complete')].map(r => parseFloat(r.children[5].textContent))")
        check(costs == sorted(costs), f"sorted by cost: {costs}")
        # RSSGD's re-weighting: a weight typed in and "Re-select" shows the API's selections for the listed κ.
        check(b.eval("document.getElementById('rescore-section').hidden") is False, "the re-weighting section is shown")
        b.eval("""(() => { document.querySelector('#rescore-weights input').value = '2';
                           document.getElementById('rescore-kappa').value = '0,1';
                           document.getElementById('rescore-go').click(); })()""")
        rs = wait_for(lambda: b.eval("window.dashboard.rescore || null"), 60, "the re-weighted selections")
        check([x["kappa"] for x in rs["selections"]] == [0, 1] and list(rs["weights"].values()) == [2],
              f"re-weighting asked as typed: {rs['weights']} {[x['kappa'] for x in rs['selections']]}")
        rows = b.eval("[...document.querySelectorAll('#rescore tr')].map(r => [...r.children].map(c => c.textContent))")
        check(len(rows) == 2 and rows[1][0] == "1", f"re-weighting table {rows}")
        b.screenshot(os.path.join(work, "dashboard_final.png"))
    print(f"browser test took {time.monotonic() - t0:.1f} s; screenshots in {work}")
    print(f"{checks} passed, 0 failed")


if __name__ == "__main__":
    main()
