"""The non-agent traffic as the loop sees it (its footprints and the drivable area are the road
frame's, `simgap.scenario.road_frame`).

Non-agent traffic comes in two modes (`TrafficMode`): ``replay`` (the default: every obstacle
follows its recording, whatever happens — a replay stays a replay) and ``idm`` (recorded vehicles
are driven along their recorded paths by an IDM towards the vehicle ahead, agents included; see
`simgap.cosim.idm`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from typing import Collection, Mapping, Protocol, Sequence

import numpy as np
from commonroad.scenario.scenario import Scenario

from simgap.planning.protocol import TrafficParticipant
from simgap.scenario.obstacles import recorded_obstacles
from simgap.trajectory import State


class TrafficMode(str, Enum):
    """How recorded traffic moves: as recorded, or reacting to the vehicle ahead."""

    REPLAY = "replay"
    IDM = "idm"


def non_agent_traffic(scenario: Scenario) -> list[TrafficParticipant]:
    """Obstacles of the scenario as they were recorded (static ones stand still for ever)."""
    return [TrafficParticipant(o.id, o.length, o.width, o.motion) for o in recorded_obstacles(scenario)]


@dataclass(frozen=True)
class ObstacleReach:
    """Where each obstacle can be during the run, so that the loop builds footprints only of the
    obstacles near an agent: a circle around every footprint of its motion (infinite for one that
    the traffic drives itself), and the time it is in the scene."""

    ids: np.ndarray          # (n,) obstacle ids, in the order `Traffic.poses` lists them
    centres: np.ndarray      # (n, 2) centres of the circles [m]
    radii: np.ndarray        # (n,) radii [m]
    t_start: np.ndarray      # (n,) when each enters the scene [s]
    t_end: np.ndarray        # (n,) when each leaves it [s]

    @classmethod
    def of(cls, recorded: Sequence[TrafficParticipant], driven: Sequence[int] = ()) -> "ObstacleReach":
        """The reach of obstacles that follow their recorded ``prediction``, then of ``driven`` ones."""
        boxes = np.array([(o.prediction.x.min(), o.prediction.y.min(), o.prediction.x.max(), o.prediction.y.max())
                          for o in recorded], dtype=float).reshape(-1, 4)
        footprint_radius = np.array([math.hypot(o.length, o.width) / 2 for o in recorded])
        n = len(driven)
        return cls(ids=np.array([o.id for o in recorded] + list(driven), dtype=int),
                   centres=np.vstack([(boxes[:, :2] + boxes[:, 2:]) / 2, np.zeros((n, 2))]),
                   radii=np.concatenate([np.hypot(*(boxes[:, 2:] - boxes[:, :2]).T) / 2 + footprint_radius,
                                         np.full(n, np.inf)]),
                   t_start=np.array([o.prediction.t[0] for o in recorded] + [-np.inf] * n),
                   t_end=np.array([o.prediction.t_end for o in recorded] + [np.inf] * n))

    def near(self, t: float, x: float, y: float, radius: float, closest: float) -> np.ndarray:
        """Indices of the obstacles in the scene at ``t`` that may come within ``closest`` of a
        vehicle of bounding ``radius`` at (``x``, ``y``), or within the distance of the obstacle
        surely nearest to it now: none of the others can touch it or be its nearest."""
        present = np.flatnonzero((self.t_start - 1e-9 <= t) & (t <= self.t_end + 1e-9))
        centre_distance = np.hypot(self.centres[present, 0] - x, self.centres[present, 1] - y)
        lower = centre_distance - self.radii[present] - radius
        upper = centre_distance + self.radii[present]
        within = min(closest, float(upper.min(initial=np.inf)))
        return present[lower <= within]


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

    def __init__(self, scenario: Scenario):
        self._participants = non_agent_traffic(scenario)
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


def make_traffic(scenario: Scenario, mode: TrafficMode) -> Traffic:
    if mode is TrafficMode.IDM:
        from simgap.cosim.idm import IdmTraffic

        return IdmTraffic(scenario)
    return ReplayedTraffic(scenario)
