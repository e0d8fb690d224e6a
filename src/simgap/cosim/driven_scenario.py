"""The driven scenario: the original scenario plus every agent as a dynamic obstacle that follows
its driven trajectory, as CommonRoad XML (so any CommonRoad tool can replay or evaluate it)."""

from __future__ import annotations

import copy

from commonroad.geometry.shape import Rectangle
from commonroad.prediction.prediction import TrajectoryPrediction
from commonroad.scenario.obstacle import DynamicObstacle, ObstacleType
from commonroad.scenario.scenario import Scenario
from commonroad.scenario.state import CustomState, InitialState
from commonroad.scenario.trajectory import Trajectory as CRTrajectory

from simgap.cosim.history import AGENT_ID_OFFSET, History


def driven_scenario(scenario: Scenario, history: History) -> Scenario:
    """A copy of ``scenario`` with each agent added as a dynamic obstacle (id offset by 100000)."""
    driven = copy.deepcopy(scenario)
    for agent in history.agents:
        traj = agent.driven
        steps = [int(round(t / history.dt)) for t in traj.t]
        first = traj[0]
        init = InitialState(time_step=steps[0], position=first.position, orientation=first.yaw,
                            velocity=first.v, acceleration=first.a, yaw_rate=first.yaw_rate,
                            slip_angle=0.0)
        rest = [CustomState(time_step=k, position=s.position, orientation=s.yaw, velocity=s.v,
                            acceleration=s.a, yaw_rate=s.yaw_rate)
                for k, s in zip(steps[1:], list(traj)[1:])]
        shape = Rectangle(agent.vehicle.length, agent.vehicle.width)
        prediction = TrajectoryPrediction(CRTrajectory(steps[1], rest), shape) if rest else None
        driven.add_objects(DynamicObstacle(AGENT_ID_OFFSET + agent.id, ObstacleType.CAR, shape,
                                           init, prediction))
    return driven
