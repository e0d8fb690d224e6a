"""Every finding of a search is followed up within its budget — probed, confirmed over seeds,
explained — and carries the command that reproduces it, bit for bit: a short real search whose
every reported violation is replayed with its printed command."""

from __future__ import annotations

import os
import shlex

import yaml
from simgap_command import simgap

from simgap.experiment.search.results import search_results
from simgap.record import read_run


def test_every_finding_of_a_short_search_is_probed_explained_and_reproduces_with_its_command(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)            # the commands name run folders relative to where the search ran
    spec = tmp_path / "late.yaml"     # a steering 0.4 s late on the tight curve: the SUV leaves the road at once
    spec.write_text(yaml.safe_dump({
        "name": "late", "logical": "curve", "parameters": {"radius": {"min": 10, "max": 11}},
        "knobs": {"steer_delay": {"min": 0.4, "max": 0.45}}, "vehicles": ["suv"],
        "ladder": [{"backend": "ideal"}, {"backend": "dynamic", "cosim": {"latency": 0.0}}],
        "failure": {"goal_missed": True}, "strategies": ["random"]}))
    env = dict(os.environ, COLUMNS="250")
    out = tmp_path / "search"
    budget = 8
    proc = simgap("search", spec, "--budget", budget, "--out", out, "--workers", "2", "--repeats", "2", "--no-report",
                  "--no-validate", env=env, cwd=tmp_path, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "(not probed)" not in proc.stdout
    (strategy,) = search_results(out).strategies
    reported = strategy.reported
    assert reported, proc.stdout
    unprobed = len(strategy.found) - len(reported)
    assert (f"{unprobed} more distinct violation" in proc.stdout) == (unprobed > 0)
    # each probed (its failure mode known), confirmed over its two seeds and explained, in the budget
    assert sum(m.count for m in strategy.modes) == len(reported)
    probes = sorted((out / "random" / "probes" / "runs").glob("*/*/run.json"))
    confirmations = sorted((out / "random" / "confirmations" / "runs").glob("*/*/r*/run.json"))
    assert len(confirmations) == len(reported) and len(probes) <= 2 * len(reported)     # radius, steer_delay
    spent = strategy.runs + len(probes) + len(confirmations) + sum(v.explanation.runs for v in reported)
    assert spent <= budget + max(2 + 1 + v.explanation.runs for v in reported)     # the last follow-up may go over
    for v in reported:
        assert v.reproduces.n == 2 and f"fails in {v.reproduces} seeds" in proc.stdout
        assert f"why: {v.explanation.sentence()}" in proc.stdout
        assert v.explanation.assumptions[0].name == "actuators"      # the steering 0.3 s late
    # every finding's printed command reproduces it, bit for bit
    commands = [line.strip() for line in proc.stdout.splitlines() if line.strip().startswith("simgap replay ")]
    assert sorted(commands) == sorted(v.reproduce for v in reported)
    for v in reported:
        again = simgap(*shlex.split(v.reproduce)[1:], env=env, cwd=tmp_path)
        assert again.returncode == 0, again.stdout + again.stderr
        assert f"reproduced: fingerprint {read_run(v.run_dir).fingerprint}" in again.stdout, again.stdout
