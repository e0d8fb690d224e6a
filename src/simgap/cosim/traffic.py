"""Road users as the loop sees them: footprints, non-agent obstacles, the drivable area."""

from __future__ import annotations

import math

import numpy as np
import shapely
from commonroad.scenario.lanelet import LaneletNetwork
from commonroad.scenario.obstacle import DynamicObstacle
from commonroad.scenario.scenario import Scenario
from shapely.geometry import Polygon
from shapely.ops import unary_union

from simgap.planning.protocol import TrafficParticipant
from simgap.trajectory import State, Trajectory


def footprint(state: State, length: float, width: float) -> Polygon:
    """The rectangle a vehicle of ``length`` x ``width`` covers, centred on ``state``."""
    c, s = math.cos(state.yaw), math.sin(state.yaw)
    hl, hw = length / 2.0, width / 2.0
    corners = [(hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw)]
    return Polygon([(state.x + c * a - s * b, state.y + s * a + c * b) for a, b in corners])


class DrivableArea:
    """The union of all lanelets; a footprint that leaves it (beyond ``tolerance``) is off road."""

    def __init__(self, network: LaneletNetwork, tolerance: float = 0.05):
        polygons = [Polygon(l.polygon.vertices).buffer(0) for l in network.lanelets]
        self.area = unary_union(polygons).buffer(tolerance)
        shapely.prepare(self.area)

    def contains(self, polygon: Polygon) -> bool:
        return bool(self.area.contains(polygon))

    def excursion(self, polygon: Polygon) -> float:
        """How far [m] the footprint reaches beyond the drivable area (0 when inside)."""
        outside = polygon.difference(self.area)
        if outside.is_empty:
            return 0.0
        boundary = self.area.boundary
        return max(boundary.distance(shapely.Point(p)) for p in np.asarray(polygon.exterior.coords))


def obstacle_trajectory(obstacle: DynamicObstacle, dt: float) -> Trajectory:
    """A non-agent obstacle's recorded motion (initial state + trajectory prediction) as a Trajectory."""
    states = [obstacle.initial_state]
    prediction = obstacle.prediction
    if prediction is not None and hasattr(prediction, "trajectory"):
        states += list(prediction.trajectory.state_list)
    rows = []
    for st in states:
        v = float(getattr(st, "velocity", 0.0) or 0.0)
        rows.append(State(
            t=st.time_step * dt, x=float(st.position[0]), y=float(st.position[1]),
            yaw=float(getattr(st, "orientation", 0.0) or 0.0), v=v,
            a=float(getattr(st, "acceleration", 0.0) or 0.0),
            yaw_rate=float(getattr(st, "yaw_rate", 0.0) or 0.0)))
    return Trajectory.from_states(rows, dt)


def non_agent_traffic(scenario: Scenario) -> list[TrafficParticipant]:
    """Dynamic obstacles of the scenario: they follow their recorded trajectory."""
    traffic = []
    for obs in scenario.dynamic_obstacles:
        shape = obs.obstacle_shape
        length = float(getattr(shape, "length", 0.0) or 2 * getattr(shape, "radius", 1.0))
        width = float(getattr(shape, "width", 0.0) or 2 * getattr(shape, "radius", 1.0))
        traffic.append(TrafficParticipant(obs.obstacle_id, length, width,
                                          obstacle_trajectory(obs, scenario.dt)))
    return traffic
