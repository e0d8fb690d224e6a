"""The non-agent traffic as the loop sees it (its footprints and the drivable area are the road
frame's, `simgap.scenario.road_frame`).

Non-agent traffic comes in two modes (`TrafficMode`): ``replay`` (the default: every obstacle
follows its recording, whatever happens — a replay stays a replay) and ``idm`` (recorded vehicles
are driven along their recorded paths by an IDM towards the vehicle ahead, agents included; see
`simgap.cosim.idm`).
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from enum import Enum
from typing import Protocol

from commonroad.scenario.scenario import Scenario

from simgap.cosim.idm import IdmTraffic
from simgap.cosim.obstacle_reach import ObstacleReach
from simgap.planning.protocol import TrafficParticipant
from simgap.scenario.obstacles import RecordedObstacle, recorded_obstacles
from simgap.trajectory import State


class TrafficMode(str, Enum):
    """How recorded traffic moves: as recorded, or reacting to the vehicle ahead."""

    REPLAY = "replay"
    IDM = "idm"


def non_agent_traffic(scenario: Scenario, obstacles: Sequence[RecordedObstacle] | None = None) -> list[TrafficParticipant]:
    """Obstacles of the scenario as they were recorded (static ones stand still for ever); ``obstacles``:
    its `recorded_obstacles`, when the caller has them."""
    obstacles = recorded_obstacles(scenario) if obstacles is None else obstacles
    return [TrafficParticipant(o.id, o.length, o.width, o.motion) for o in obstacles]


class Traffic(Protocol):
    """The non-agent traffic of one run (`ReplayedTraffic`, or `simgap.cosim.idm.IdmTraffic`)."""

    reach: ObstacleReach
    driven_ids: tuple[int, ...]      # the obstacles it drives itself (not as recorded)

    def participants(self) -> Sequence[TrafficParticipant]:
        """Every obstacle as planners see it now: its size and predicted motion."""

    def poses(self, t: float, ids: Collection[int] | None = None) -> dict[int, tuple[State, float, float]]:
        """Obstacles in the scene at ``t`` (of ``ids`` only, when given): (centre state, length, width) by id."""

    def advance(self, t: float, dt: float, agents: Mapping[int, TrafficParticipant]) -> None:
        """Move the traffic from ``t`` to ``t + dt``; ``agents`` stand where they are at ``t``."""


class ReplayedTraffic:
    """Every obstacle follows its recording."""

    def __init__(self, scenario: Scenario, obstacles: Sequence[RecordedObstacle] | None = None):
        self._participants = non_agent_traffic(scenario, obstacles)
        self._by_id = {o.id: o for o in self._participants}
        self.reach = ObstacleReach.of(self._participants)
        self.driven_ids: tuple[int, ...] = ()

    def participants(self) -> Sequence[TrafficParticipant]:
        return self._participants

    def poses(self, t: float, ids: Collection[int] | None = None) -> dict[int, tuple[State, float, float]]:
        chosen = self._participants if ids is None else [self._by_id[i] for i in ids]
        return {o.id: (o.prediction.at(t), o.length, o.width) for o in chosen
                if o.prediction.t[0] - 1e-9 <= t <= o.prediction.t_end + 1e-9}

    def advance(self, t: float, dt: float, agents: Mapping[int, TrafficParticipant]) -> None:
        pass


def make_traffic(scenario: Scenario, mode: TrafficMode, obstacles: Sequence[RecordedObstacle] | None = None) -> Traffic:
    """The scenario's traffic in ``mode`` (``obstacles``: its `recorded_obstacles`, when the caller has them)."""
    if mode is TrafficMode.IDM:
        return IdmTraffic(scenario, obstacles=obstacles)
    return ReplayedTraffic(scenario, obstacles)
