"""The other road users of a run, as the closed-loop score sees them: every other agent on its
driven trajectory, and every obstacle of the scenario on its recorded motion, each with its box and
its kind (nuPlan's three: vehicle, vulnerable road user, static object).

With ``traffic: idm`` the run does not record where the IDM drove the obstacles; their recorded
motion stands in for it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
from commonroad.scenario.obstacle import ObstacleType
from commonroad.scenario.scenario import Scenario

from simgap.cosim.history import History
from simgap.scenario.obstacles import RecordedObstacle, recorded_obstacles
from simgap.trajectory import Trajectory


class RoadUserKind(StrEnum):
    VEHICLE = "vehicle"
    VRU = "vru"             # pedestrians and cyclists
    OBJECT = "object"       # static objects: construction zones, barriers, buildings, ...


_VRU_TYPES = {ObstacleType.PEDESTRIAN, ObstacleType.BICYCLE}
_OBJECT_TYPES = {ObstacleType.CONSTRUCTION_ZONE, ObstacleType.ROAD_BOUNDARY, ObstacleType.BUILDING,
                 ObstacleType.PILLAR, ObstacleType.MEDIAN_STRIP}


def kind_of(obstacle_type: ObstacleType) -> RoadUserKind:
    if obstacle_type in _VRU_TYPES:
        return RoadUserKind.VRU
    if obstacle_type in _OBJECT_TYPES:
        return RoadUserKind.OBJECT
    return RoadUserKind.VEHICLE


@dataclass(frozen=True)
class MotionAt:
    """Road users' centre states at given times (arrays: one entry per time)."""

    present: np.ndarray     # bool: in the scene at that time
    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    v: np.ndarray


@dataclass(frozen=True)
class RoadUser:
    id: int
    kind: RoadUserKind
    length: float
    width: float
    motion: Trajectory      # centre states

    def at(self, t: np.ndarray) -> MotionAt:
        """Where it is at each of the times ``t`` (linearly interpolated; absent outside its motion)."""
        m = self.motion
        present = (t >= m.t[0] - 1e-9) & (t <= m.t_end + 1e-9)
        if len(m) == 1:
            return MotionAt(present, np.full(len(t), m.x[0]), np.full(len(t), m.y[0]), np.full(len(t), m.yaw[0]),
                            np.full(len(t), m.v[0]))
        return MotionAt(present, np.interp(t, m.t, m.x), np.interp(t, m.t, m.y),
                        np.interp(t, m.t, np.unwrap(m.yaw)), np.interp(t, m.t, m.v))


def road_users(history: History, scenario: Scenario,
               obstacles: Sequence[RecordedObstacle] | None = None) -> dict[int, RoadUser]:
    """Every agent (on its driven trajectory) and every obstacle (on its recorded motion), by id
    (``obstacles``: the scenario's `recorded_obstacles`, when the caller has them)."""
    out = {}
    for obstacle in recorded_obstacles(scenario) if obstacles is None else obstacles:
        kind = kind_of(scenario.obstacle_by_id(obstacle.id).obstacle_type)
        out[obstacle.id] = RoadUser(obstacle.id, kind, obstacle.length, obstacle.width, obstacle.motion)
    for agent in history.agents:
        out[agent.id] = RoadUser(agent.id, RoadUserKind.VEHICLE, agent.vehicle.length, agent.vehicle.width,
                                 agent.driven)
    return out
