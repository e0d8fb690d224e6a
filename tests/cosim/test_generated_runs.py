"""Whole low-fidelity runs of generated scenarios with the Frenet planner."""

from __future__ import annotations

import numpy as np
import pytest
from commonroad.geometry.shape import Rectangle
from commonroad.prediction.prediction import TrajectoryPrediction
from commonroad.scenario.obstacle import DynamicObstacle, ObstacleType
from commonroad.scenario.state import CustomState, InitialState
from commonroad.scenario.trajectory import Trajectory as CRTrajectory
from evaluated import recorded

from simgap.cosim import CosimSettings, simulate
from simgap.cosim.agents import agents_from_problems
from simgap.planning.frenet import FrenetPlanner
from simgap.planning.protocol import PlannerSetup
from simgap.scenario import build_scenario
from simgap.sim.ideal import IdealBackend
from simgap.vehicles import load_vehicle


def run_ideal(concrete, replan_every=1):
    scenario, problems = concrete.scenario, concrete.problems
    sedan = load_vehicle("sedan")
    agents = agents_from_problems(problems, scenario.dt, sedan)
    planners = {a.id: FrenetPlanner(PlannerSetup.for_problem(problems.planning_problem_dict[a.id], sedan, scenario.lanelet_network))
                for a in agents}
    return recorded(simulate(scenario, problems, IdealBackend(), agents, planners,
                             CosimSettings(replan_every=replan_every)), scenario, problems)


@pytest.mark.parametrize("radius, angle", [(10, -180), (10, 180), (100, -180), (100, 180)])
def test_curve_grid_corners_reach_the_goal(radius, angle):
    run = run_ideal(build_scenario("curve", {"radius": radius, "angle": angle}), replan_every=3)
    (agent,) = run.agents
    assert agent.history.outcome == "goal_reached", run.history.events
    assert agent.evaluation.max_road_excursion_m == 0.0


@pytest.mark.parametrize("logical", ["t-junction", "intersection"])
def test_three_agents_cross_a_junction_without_collision(logical):
    run = run_ideal(build_scenario(logical, {"agents": 3}))
    assert [a.history.outcome for a in run.agents] == ["goal_reached"] * 3, run.history.events
    assert min(a.evaluation.min_distance_to_traffic_m for a in run.agents) > 0.0
    assert not [e for e in run.history.events if e.kind == "collision"]


def test_recorded_obstacle_is_traffic_the_planner_avoids():
    concrete = build_scenario("curve", {"radius": 50, "angle": 0, "initial_speed": 10})
    scenario = concrete.scenario
    lane = min(scenario.lanelet_network.lanelets, key=lambda l: l.lanelet_id)   # the agent's lane
    start = lane.center_vertices[0] + np.array([45.0, 0.0])
    states = [CustomState(time_step=k, position=start + np.array([3.0 * 0.1 * k, 0.0]), orientation=0.0,
                          velocity=3.0) for k in range(1, 400)]
    shape = Rectangle(4.5, 1.8)
    obstacle = DynamicObstacle(
        scenario.generate_object_id(), ObstacleType.CAR, shape,
        InitialState(time_step=0, position=start, orientation=0.0, velocity=3.0, acceleration=0.0,
                     yaw_rate=0.0, slip_angle=0.0),
        TrajectoryPrediction(CRTrajectory(1, states), shape))
    scenario.add_objects(obstacle)
    run = run_ideal(concrete)
    (agent,) = run.agents
    assert agent.history.outcome != "collision", run.history.events
    assert 0.0 < agent.evaluation.min_distance_to_traffic_m < 10.0   # it met the obstacle, and kept clear of it
