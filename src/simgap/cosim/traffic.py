"""Road users as the loop sees them: footprints, non-agent obstacles, the drivable area."""

from __future__ import annotations

import math

import numpy as np
import shapely
from commonroad.scenario.lanelet import LaneletNetwork
from commonroad.scenario.scenario import Scenario
from shapely.geometry import Polygon
from shapely.ops import unary_union

from simgap.planning.protocol import TrafficParticipant
from simgap.scenario.obstacles import recorded_obstacles
from simgap.trajectory import State


def footprint(state: State, length: float, width: float) -> Polygon:
    """The rectangle a vehicle of ``length`` x ``width`` covers, centred on ``state``."""
    c, s = math.cos(state.yaw), math.sin(state.yaw)
    hl, hw = length / 2.0, width / 2.0
    corners = [(hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw)]
    return Polygon([(state.x + c * a - s * b, state.y + s * a + c * b) for a, b in corners])


class DrivableArea:
    """The union of all lanelets (or of ``lanelet_ids``: a route's lanes); a footprint that leaves
    it (beyond ``tolerance``) is off road (or off its lanes)."""

    def __init__(self, network: LaneletNetwork, tolerance: float = 0.05, lanelet_ids: list[int] | None = None):
        lanelets = network.lanelets if lanelet_ids is None else [network.find_lanelet_by_id(i) for i in lanelet_ids]
        polygons = [Polygon(l.polygon.vertices).buffer(0) for l in lanelets]
        self.area = unary_union(polygons).buffer(tolerance)
        shapely.prepare(self.area)

    def contains(self, polygon: Polygon) -> bool:
        return bool(self.area.contains(polygon))

    def excursion(self, polygon: Polygon) -> float:
        """How far [m] the footprint reaches beyond the drivable area (0 when inside): the
        largest distance of a footprint corner from the area."""
        if self.area.contains(polygon):
            return 0.0
        corners = np.asarray(polygon.exterior.coords)
        return float(shapely.distance(self.area, shapely.points(corners)).max())


def non_agent_traffic(scenario: Scenario) -> list[TrafficParticipant]:
    """Dynamic obstacles of the scenario: they follow their recorded trajectory."""
    return [TrafficParticipant(o.id, o.length, o.width, o.motion) for o in recorded_obstacles(scenario)]
