"""The score table of a results store (what bench/paper/paper_study.py prints), on rows made up by hand."""

from __future__ import annotations

import pytest

from simgap.cosim import Fidelity
from simgap.experiment.job import JobId
from simgap.experiment.run_row import RunRow
from simgap.report.scores import store_score_rows

ONES = {name: 1.0 for name in ("at_fault_collisions", "drivable_area", "driving_direction", "making_progress",
                               "progress", "time_to_collision", "speed_limit", "comfort")}


def row(scenario, fidelity, score, valid, reason="", cost=100.0, **components):
    backend, _, vehicle = fidelity.partition("/")
    return RunRow(JobId(scenario, Fidelity(backend, vehicle or "sedan")), {}, vehicle or "sedan", "ok", score=score,
                  solution_valid=valid, solution_reason=reason, solution_cost=cost,
                  score_components=ONES | {k[len("score_"):]: v for k, v in components.items()})


def test_drops_the_component_that_explains_them_and_solutions_that_broke():
    rows = [row("a", "ideal", 0.875, True, score_comfort=0.0),
            row("a", "mujoco/suv", 0.5625, False, "infeasible for KS2 at t = 3.1 s (no input ...)", cost=80.0,
                score_comfort=0.0, score_time_to_collision=0.0),       # lost the TTC: 5/16 of the score
            row("b", "ideal", 1.0, True),
            row("b", "mujoco/suv", 1.0, True, cost=60.0),
            row("c", "ideal", 1.0, False, "goal not reached"),
            row("c", "mujoco/suv", 0.0, False, "goal not reached", score_drivable_area=0.0)]
    (r,) = store_score_rows(rows)
    assert r["fidelity"] == "mujoco/suv" and r["runs"] == 3
    assert r["ideal score"] == pytest.approx((0.875 + 1 + 1) / 3) and r["score"] == pytest.approx(1.5625 / 3)
    assert r["mean drop"] == pytest.approx((0.3125 + 0 + 1) / 3) and r["largest drop"] == pytest.approx(1.0)
    assert r["runs that lost"] == 2
    assert r["lost most on"].startswith("drivable_area (0.333)") and "time_to_collision (0.104)" in r["lost most on"]
    assert r["ideal valid"] == 2 and r["valid"] == 1
    assert r["ideal-valid now invalid"] == 1 and r["because"] == "infeasible (1)"     # c was invalid already
    assert r["ideal cost"] == pytest.approx(100.0) and r["cost"] == pytest.approx(80.0)
