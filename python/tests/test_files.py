"""Files varbo writes, read by the tools users have (red team, session 30): config.resolved.yaml loaded and dumped
by PyYAML (YAML 1.1, as ROS 1's rosparam) runs the same study again."""
import csv

import pytest

from conftest import run_cli

yaml = pytest.importorskip("yaml")

CONFIG = """\
task: {type: external, command: 'echo 1.5'}
parameters:
  - {name: lr, type: categorical, choices: [1e-3, 0.01, .1]}
  - {name: mode, type: categorical, choices: [on, off]}
  - {name: batch, type: categorical, choices: [1, 2, 4]}
  - {name: h3, type: fixed, value: off}
  - {name: g, type: real, low: 0, high: 1}
budget: 6
seed: 4
algorithm: {type: bo, initial_points: 3, failure_model: {feasible_region: off}}
"""


def test_resolved_configuration_survives_a_pyyaml_round_trip(tmp_path):
    cfg = tmp_path / "c.yaml"
    cfg.write_text(CONFIG)
    run_cli("-q", "run", cfg, "-o", tmp_path / "a", "--no-progress")
    text = (tmp_path / "a" / "config.resolved.yaml").read_text()
    assert 'feasible_region: "off"' in text and '"1e-3"' in text and '".1"' in text
    d = yaml.safe_load(text)
    assert d["algorithm"]["failure_model"]["feasible_region"] == "off"  # not False
    assert d["parameters"][0]["choices"] == ["1e-3", 0.01, ".1"]
    assert d["parameters"][1]["choices"] == ["on", "off"]
    d["output"] = str(tmp_path / "b")
    (tmp_path / "rt.yaml").write_text(yaml.safe_dump(d))
    run_cli("-q", "run", tmp_path / "rt.yaml", "--no-progress")

    def rows(folder):
        with open(folder / "trials.csv", newline="") as f:
            return [r[:8] for r in csv.reader(f)]

    assert rows(tmp_path / "a") == rows(tmp_path / "b")  # the same study: labels, θ, costs
