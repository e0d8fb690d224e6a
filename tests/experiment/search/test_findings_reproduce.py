"""Every finding of a search carries the command that reproduces it, and the command does; it is
confirmed over seeds in high fidelity."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import yaml

from simgap.experiment.search.results import search_results

ROOT = Path(__file__).resolve().parents[3]


def test_a_finding_of_a_short_search_reproduces_with_its_command(tmp_path):
    spec = tmp_path / "late.yaml"                    # a steering 0.3 s late on tight curves: the SUV leaves its lane
    spec.write_text(yaml.safe_dump({
        "name": "late", "logical": "curve", "parameters": {"radius": {"min": 10, "max": 12}, "angle": {"min": 80, "max": 90}},
        "knobs": {"steer_delay": {"min": 0.28, "max": 0.3}}, "vehicles": ["suv"],
        "ladder": [{"backend": "ideal"}, {"backend": "mujoco"}], "failure": {"goal_missed": True,
                                                                             "above": {"max_lane_excursion_m": 0.1}},
        "strategies": ["random"]}))
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"), COLUMNS="250", MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    out = tmp_path / "search"
    proc = subprocess.run([sys.executable, "-m", "simgap", "search", str(spec), "--budget", "4", "--out", str(out),
                           "--workers", "2", "--probe-runs", "0", "--repeats", "2", "--explain", "1", "--no-report", "--no-validate"], env=env,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    found = [v for r in search_results(out).strategies for v in r.found]
    assert found, proc.stdout
    for v in found:
        assert v.reproduce in proc.stdout                 # printed, worst first
        assert v.reproduces.n == 2 and v.reproduces.k >= 1 and f"fails in {v.reproduces} seeds" in proc.stdout
    explained = [v for v in found if v.explanation is not None]
    assert len(explained) == 1 and f"why: {explained[0].explanation.sentence()}" in proc.stdout
    assert explained[0].explanation.assumptions[0].name == "actuators"     # the steering 0.3 s late
    confirmations = sorted((out / "random" / "confirmations" / "runs").glob("*/*/r*/run.json"))
    assert len(confirmations) == len(found)           # one more seed each, in high fidelity
    command = found[0].reproduce.split()
    assert command[:2] == ["simgap", "replay"]
    again = subprocess.run([sys.executable, "-m", "simgap", *command[1:]], env=env, capture_output=True, text=True,
                           timeout=300)
    assert again.returncode == 0 and "reproduced: fingerprint" in again.stdout, again.stdout + again.stderr
