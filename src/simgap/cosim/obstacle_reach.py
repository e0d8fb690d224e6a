"""`ObstacleReach`: where each obstacle of a run can be, so that the loop builds footprints only of
the obstacles near an agent (every kind of traffic, `simgap.cosim.traffic`, has one)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from simgap.planning.protocol import TrafficParticipant


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
    def of(cls, recorded: Sequence[TrafficParticipant], driven: Sequence[int] = ()) -> ObstacleReach:
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
