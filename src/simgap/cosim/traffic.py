"""Road users as the loop sees them: footprints, the drivable area, and the non-agent traffic.

Non-agent traffic comes in two modes (`TrafficMode`): ``replay`` (the default: every obstacle
follows its recording, whatever happens — a replay stays a replay) and ``idm`` (recorded vehicles
are driven along their recorded paths by an IDM towards the vehicle ahead, agents included; see
`simgap.cosim.idm`).
"""

from __future__ import annotations

import math
from enum import Enum
from typing import Mapping, Protocol, Sequence

import numpy as np
import shapely
from commonroad.scenario.lanelet import LaneletNetwork
from commonroad.scenario.scenario import Scenario
from shapely.geometry import Polygon
from shapely.ops import unary_union

from simgap.planning.protocol import TrafficParticipant
from simgap.scenario.obstacles import recorded_obstacles
from simgap.trajectory import State


class TrafficMode(str, Enum):
    """How recorded traffic moves: as recorded, or reacting to the vehicle ahead."""

    REPLAY = "replay"
    IDM = "idm"


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
    """Obstacles of the scenario as they were recorded (static ones stand still for ever)."""
    return [TrafficParticipant(o.id, o.length, o.width, o.motion) for o in recorded_obstacles(scenario)]


class Traffic(Protocol):
    """The non-agent traffic of one run (`ReplayedTraffic`, or `simgap.cosim.idm.IdmTraffic`)."""

    def participants(self) -> Sequence[TrafficParticipant]:
        """Every obstacle as planners see it now: its size and predicted motion."""

    def poses(self, t: float) -> dict[int, tuple[State, float, float]]:
        """Obstacles in the scene at ``t``: (centre state, length, width) by id."""

    def advance(self, t: float, dt: float, agents: Mapping[int, TrafficParticipant]) -> None:
        """Move the traffic from ``t`` to ``t + dt``; ``agents`` stand where they are at ``t``."""


class ReplayedTraffic:
    """Every obstacle follows its recording."""

    def __init__(self, scenario: Scenario):
        self._participants = non_agent_traffic(scenario)

    def participants(self) -> Sequence[TrafficParticipant]:
        return self._participants

    def poses(self, t: float) -> dict[int, tuple[State, float, float]]:
        return {o.id: (o.prediction.at(t), o.length, o.width) for o in self._participants
                if o.prediction.t[0] - 1e-9 <= t <= o.prediction.t_end + 1e-9}

    def advance(self, t: float, dt: float, agents: Mapping[int, TrafficParticipant]) -> None:
        pass


def make_traffic(scenario: Scenario, mode: TrafficMode) -> Traffic:
    if mode is TrafficMode.IDM:
        from simgap.cosim.idm import IdmTraffic

        return IdmTraffic(scenario)
    return ReplayedTraffic(scenario)
