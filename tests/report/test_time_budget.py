"""Where an experiment's time went, from its store: every phase of every run is accounted for,
none negative, per fidelity and in all."""

from __future__ import annotations

import math

import yaml

from simgap.experiment.runner import run_experiment
from simgap.report.time_budget import PHASES, budget_lines, store_budget

TWO_WORLDS = {"name": "budget", "logical": "curve",
              "parameters": {"radius": {"values": [20, 50]}, "angle": {"values": [30]}},
              "fidelities": [{"backend": "ideal"}, {"backend": "mujoco", "vehicles": ["city"]}],
              "cosim": {"replan_every": 3, "max_time_s": 6.0}}


def test_the_budget_accounts_for_every_second_of_every_run(tmp_path):
    spec, out = tmp_path / "spec.yaml", tmp_path / "out"
    spec.write_text(yaml.safe_dump(TWO_WORLDS))
    result = run_experiment(spec, out, workers=1, validate=True)
    budgets = store_budget(out)
    assert set(budgets) == {"low", "high", "all"}
    assert budgets["low"].runs == budgets["high"].runs == 2 and budgets["all"].runs == 4
    for fid, b in budgets.items():
        for p in PHASES:
            assert b.phases[p] >= 0.0, f"{fid}: {p} is {b.phases[p]}"
        assert math.isclose(sum(b.phases.values()), b.job_s, rel_tol=1e-9)
        assert b.phases["planning"] > 0 and b.phases["validation"] > 0
    assert budgets["low"].phases["physics"] == 0.0 < budgets["high"].phases["physics"]
    assert budgets["high"].phases["control"] > 0
    for p in PHASES:
        assert math.isclose(budgets["all"].phases[p], budgets["low"].phases[p] + budgets["high"].phases[p])
    lines = budget_lines(budgets, result.wall_time_s, 1)
    assert lines[-1].startswith("wall ") and "planning" in lines[1]
