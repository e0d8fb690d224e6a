"""Scores of whole runs: an at-fault collision scores 0, being hit from behind does not; a planner
that drives off the road scores 0, whatever else it did (through `simgap run`'s own code path)."""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import numpy as np
import pytest
from commonroad.common.util import Interval
from commonroad.geometry.shape import Rectangle
from commonroad.planning.goal import GoalRegion
from commonroad.planning.planning_problem import PlanningProblem, PlanningProblemSet
from commonroad.scenario.state import CustomState
from cosim.real_like import DT, box_goal, highway, recorded_car, start

from simgap.cosim import CosimSettings, Outcome, simulate
from simgap.cosim.agents import agents_from_problems
from simgap.evaluate.closed_loop_score import closed_loop_scores
from simgap.evaluate.settings import ScoreSettings
from simgap.experiment.single_run import RunRequest, execute
from simgap.planning.registry import PlannerChoice
from simgap.scenario import build_scenario, write_scenario
from simgap.sim.ideal import IdealBackend
from simgap.trajectory import State, Trajectory
from simgap.vehicles import load_vehicle

STRAIGHT_AHEAD = textwrap.dedent('''
    """Keeps its speed (at least 8 m/s) and heading, whatever the road does."""
    import numpy as np
    from simgap.trajectory import Trajectory


    class StraightAhead:
        def __init__(self, setup, settings):
            pass

        def plan(self, observed, t, world):
            n, v = 31, max(observed.v, 8.0)
            k = np.arange(n)
            s = v * world.dt * k
            return Trajectory(world.dt, t=t + world.dt * k, x=observed.x + s * np.cos(observed.yaw),
                              y=observed.y + s * np.sin(observed.yaw), yaw=np.full(n, observed.yaw),
                              v=np.full(n, v), a=np.zeros(n), yaw_rate=np.zeros(n), steer=np.zeros(n))
''')


class Cruise:
    """Keeps the speed it starts with, straight ahead, blind to everyone."""

    def __init__(self, speed: float):
        self.speed = speed

    def plan(self, observed: State, t: float, world) -> Trajectory:
        n = 31
        k = np.arange(n)
        s = self.speed * world.dt * k
        return Trajectory(world.dt, t=t + world.dt * k, x=observed.x + s, y=np.full(n, observed.y),
                          yaw=np.zeros(n), v=np.full(n, self.speed), a=np.zeros(n), yaw_rate=np.zeros(n),
                          steer=np.zeros(n))


def cruise_past(obstacle, speed: float):
    """Ego (planning problem 1) cruising in lane 0 of a highway at ``speed``, with ``obstacle``."""
    scenario = highway(lanes=2)
    scenario.add_objects(obstacle)
    problems = PlanningProblemSet([PlanningProblem(1, start(10.0, 0, speed), box_goal(400.0, 0, (0, 600)))])
    agents = agents_from_problems(problems, DT, load_vehicle("sedan"))
    run = simulate(scenario, problems, IdealBackend(), agents, {1: Cruise(speed)}, CosimSettings(max_time_s=20.0))
    return run, closed_loop_scores(run, scenario, problems, ScoreSettings(), CosimSettings().offroad_tolerance)[1]


def test_driving_into_a_standing_car_is_at_fault_and_scores_zero():
    run, score = cruise_past(recorded_car(50, 60.0, 0, 0.0, 300), speed=10.0)
    assert run.agents[0].outcome == Outcome.COLLISION
    assert score.components["at_fault_collisions"] == 0.0 and score.score == 0.0
    assert score.measures["collision"] == 1.0 and score.measures["collision_stopped_track"] == 1.0
    assert score.components["time_to_collision"] == 0.0           # the TTC fell to 0 when it hit


def test_being_hit_from_behind_is_not_the_egos_fault():
    run, score = cruise_past(recorded_car(50, -30.0, 0, 15.0, 300), speed=5.0)
    assert run.agents[0].outcome == Outcome.COLLISION
    assert score.measures["collision_active_rear"] == 1.0 and score.measures["collision"] == 0.0
    assert score.components["at_fault_collisions"] == 1.0


def test_a_planner_that_drives_off_the_road_scores_zero(tmp_path):
    planner = tmp_path / "straight_ahead.py"
    planner.write_text(STRAIGHT_AHEAD)
    curve = write_scenario(build_scenario("curve", {"radius": 10.0, "angle": 90.0}), tmp_path, preview=False)
    run = execute(RunRequest(curve, planner=PlannerChoice(planner=f"{planner}:StraightAhead"), validate=True), tmp_path / "run")
    assert run.history.agents[0].outcome == Outcome.OFF_ROAD
    agent = run.evaluation.agents[0]
    assert agent.score == 0.0 and agent.score_components["drivable_area"] == 0.0
    assert agent.solution_valid is False and agent.solution_reason.startswith("goal not reached")
    saved = json.loads((tmp_path / "run" / "run.json").read_text())["evaluation"]["agents"][0]
    assert saved["score"] == 0.0 and saved["solution_valid"] is False and saved["solution_cost"] > 0
    assert Path(tmp_path / "run" / "solution.xml").is_file()


@pytest.mark.parametrize("speed", [0.0, 5.0])
def test_without_a_route_to_the_goal_standing_or_driving_away_makes_no_progress(speed):
    # the goal lies behind the start on a one-way road: no lanelet route leads to it (the Frenet
    # planner refuses the problem); a planner that stands or drives on closes no distance to it
    scenario = highway(lanes=1, length=200, segments=2)
    goal = GoalRegion([CustomState(time_step=Interval(0, 100), position=Rectangle(10.0, 3.0, np.array([20.0, 1.75])))])
    problems = PlanningProblemSet([PlanningProblem(1, start(150.0, 0, speed), goal)])
    agents = agents_from_problems(problems, DT, load_vehicle("sedan"))
    run = simulate(scenario, problems, IdealBackend(), agents, {1: Cruise(speed)}, CosimSettings(max_time_s=6.0))
    assert run.agents[0].outcome == Outcome.TIMEOUT
    score = closed_loop_scores(run, scenario, problems, ScoreSettings(), CosimSettings().offroad_tolerance)[1]
    assert score.measures["goal_progress_m"] == pytest.approx(125.0)
    assert score.measures["progress_m"] == pytest.approx(-speed * 6.0, abs=0.01)
    assert score.components["making_progress"] == 0.0 and score.score == 0.0
