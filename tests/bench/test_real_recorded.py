"""Smoke test of bench/recorded/real_recorded.py on a file shaped like a converted recording: a planning
problem with its human driver's vehicle beside it (a dynamic obstacle at the same initial state).
The bench reports numbers, not pass/fail; this checks that it runs end to end, tells the human
driver from the traffic and counts both."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from commonroad.geometry.shape import Rectangle
from commonroad.prediction.prediction import TrajectoryPrediction
from commonroad.scenario.obstacle import DynamicObstacle, ObstacleType
from commonroad.scenario.state import InitialState, KSState
from commonroad.scenario.trajectory import Trajectory as CrTrajectory

from simgap.scenario import build_scenario
from simgap.scenario.files import write_scenario


@pytest.fixture(scope="module")
def real_recorded(bench_module):
    return bench_module("recorded/real_recorded")


def recording(tmp_path: Path) -> Path:
    """The curve with the problem's own recorded vehicle: at its initial state, then driving on
    straight at 10 m/s for 3 s (it does not reach the goal)."""
    concrete = build_scenario("curve", {"radius": 50, "angle": 30})
    (problem,) = concrete.problems.planning_problem_dict.values()
    start = problem.initial_state
    heading = float(start.orientation)
    states = [KSState(time_step=k, position=np.asarray(start.position) + 1.0 * k * np.array([np.cos(heading), np.sin(heading)]),
                      orientation=heading, velocity=10.0, steering_angle=0.0) for k in range(1, 31)]
    initial = InitialState(position=np.asarray(start.position), orientation=heading, velocity=10.0, time_step=0,
                           acceleration=0.0, yaw_rate=0.0, slip_angle=0.0)
    shape = Rectangle(4.5, 1.8)
    concrete.scenario.add_objects(DynamicObstacle(
        concrete.scenario.generate_object_id(), ObstacleType.CAR, shape, initial,
        TrajectoryPrediction(CrTrajectory(1, states), shape)))
    return write_scenario(concrete, tmp_path, preview=False)


def test_a_recording_with_its_human_driver_runs_and_is_counted(real_recorded, tmp_path):
    xml = recording(tmp_path)
    humans = real_recorded.human_outcomes(xml)
    assert len(humans) == 1 and next(iter(humans.values())).startswith("misses:")
    (result,) = real_recorded.run_one((xml, "ideal", "highway", "replay", "frenet", None, None))
    assert result.outcome == "goal_reached" and result.human.startswith("misses:") and not result.excluded
    table, errors, wall = real_recorded.rates([result], "ideal")
    assert table["highway"] == (1, 1) and table["all"] == (1, 1) and errors == 0 and wall > 0
