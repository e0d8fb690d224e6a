"""Scenarios built in code that carry the features of real CommonRoad files (NGSIM/highD-style
goal windows, lane-change goals, circle / polygon / set-based obstacles, recorded traffic)."""

from __future__ import annotations

import math

import numpy as np
from commonroad.common.util import AngleInterval, Interval
from commonroad.geometry.shape import Circle, Rectangle
from commonroad.planning.goal import GoalRegion
from commonroad.planning.planning_problem import PlanningProblem, PlanningProblemSet
from commonroad.prediction.prediction import TrajectoryPrediction
from commonroad.scenario.lanelet import Lanelet, LaneletNetwork
from commonroad.scenario.obstacle import DynamicObstacle, ObstacleType
from commonroad.scenario.scenario import Scenario
from commonroad.scenario.state import CustomState, InitialState, KSState
from commonroad.scenario.trajectory import Trajectory as CrTrajectory
from evaluated import recorded

from simgap.cosim import CosimSettings, simulate
from simgap.cosim.agents import agents_from_problems
from simgap.planning.frenet import FrenetPlanner
from simgap.planning.protocol import PlannerSetup
from simgap.sim.ideal import IdealBackend
from simgap.vehicles import load_vehicle

DT = 0.1
LANE = 3.5


def highway(lanes: int = 3, length: float = 500.0, segments: int = 2) -> Scenario:
    """``lanes`` parallel lanes in +x (lane 0 on the right), each cut into ``segments`` lanelets;
    lanelet id = 10 * (lane + 1) + segment."""
    scenario = Scenario(DT)
    piece = length / segments
    lanelets = []
    for lane in range(lanes):
        for seg in range(segments):
            x = np.linspace(seg * piece, (seg + 1) * piece, 20)
            right, left = lane * LANE, (lane + 1) * LANE
            lid = 10 * (lane + 1) + seg
            lanelets.append(Lanelet(
                np.stack([x, np.full_like(x, left)], 1), np.stack([x, np.full_like(x, (left + right) / 2)], 1),
                np.stack([x, np.full_like(x, right)], 1), lid,
                predecessor=[lid - 1] if seg else None, successor=[lid + 1] if seg < segments - 1 else None,
                adjacent_left=lid + 10 if lane < lanes - 1 else None, adjacent_left_same_direction=True,
                adjacent_right=lid - 10 if lane else None, adjacent_right_same_direction=True))
    scenario.add_objects(LaneletNetwork.create_from_lanelet_list(lanelets))
    return scenario


def lane_y(lane: int) -> float:
    return (lane + 0.5) * LANE


def start(x: float, lane: int, v: float, y_offset: float = 0.0, yaw: float = 0.0) -> InitialState:
    return InitialState(position=np.array([x, lane_y(lane) + y_offset]), orientation=yaw, velocity=v,
                        acceleration=0.0, yaw_rate=0.0, slip_angle=0.0, time_step=0)


def box_goal(x: float, lane: int, steps: tuple[int, int], velocity: tuple[float, float] | None = None,
             size: tuple[float, float] = (10.0, 3.0), orientation: tuple[float, float] | None = None) -> GoalRegion:
    fields = {"time_step": Interval(*steps), "position": Rectangle(*size, np.array([x, lane_y(lane)]))}
    if velocity is not None:
        fields["velocity"] = Interval(*velocity)
    if orientation is not None:
        fields["orientation"] = AngleInterval(*orientation)
    return GoalRegion([CustomState(**fields)])


def lanelet_goal(scenario: Scenario, lanelet_id: int, steps: tuple[int, int],
                 velocity: tuple[float, float] | None = None) -> GoalRegion:
    lanelet = scenario.lanelet_network.find_lanelet_by_id(lanelet_id)
    fields = {"time_step": Interval(*steps), "position": lanelet.polygon}
    if velocity is not None:
        fields["velocity"] = Interval(*velocity)
    return GoalRegion([CustomState(**fields)], lanelets_of_goal_position={0: [lanelet_id]})


def recorded_car(oid: int, x: float, lane: int, v: float, steps: int, shape=None,
                 kind: ObstacleType = ObstacleType.CAR, dy_per_step: float = 0.0) -> DynamicObstacle:
    """A car recorded driving at constant speed ``v`` along its lane (or drifting by ``dy_per_step``)."""
    shape = shape or Rectangle(4.5, 1.8)
    y = lane_y(lane)
    yaw = math.atan2(dy_per_step, v * DT) if v else 0.0
    states = [KSState(time_step=k, position=np.array([x + v * DT * k, y + dy_per_step * k]), orientation=yaw,
                      velocity=v, steering_angle=0.0) for k in range(1, steps + 1)]
    init = InitialState(position=np.array([x, y]), orientation=yaw, velocity=v, time_step=0)
    return DynamicObstacle(oid, kind, shape, init, TrajectoryPrediction(CrTrajectory(1, states), shape))


def run_ego(scenario: Scenario, initial: InitialState, goal: GoalRegion, backend=None, settings=None,
            planner_settings=None):
    """One ego agent (planning problem 1) with the Frenet planner; returns its `RunRecord`."""
    problems = PlanningProblemSet([PlanningProblem(1, initial, goal)])
    sedan = load_vehicle("sedan")
    agents = agents_from_problems(problems, DT, sedan)
    planner = FrenetPlanner(PlannerSetup.for_problem(problems.planning_problem_dict[1], sedan, scenario.lanelet_network), planner_settings)
    settings = settings or CosimSettings()
    return recorded(simulate(scenario, problems, backend or IdealBackend(), agents, {1: planner}, settings),
                    scenario, problems, settings)


__all__ = ["Circle", "box_goal", "highway", "lane_y", "lanelet_goal", "recorded_car", "run_ego", "start"]
