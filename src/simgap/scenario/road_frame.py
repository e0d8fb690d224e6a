"""The road frame: where a vehicle stands relative to the road, the shared words of the planners,
the loop and the evaluation, below all of them.

* `PathFrame` — the Frenet frame of a polyline (a lane's centre line, a route's reference path):
  arc length s and signed lateral offset d (positive to the left of the path's direction). The
  `idm` planner projects positions and traffic onto its route with it; the evaluation measures
  lateral displacement d(s) in it. (The Frenet planner's frame on the frenetix core,
  `simgap.planning.frenet_frame`, adds the core's local planning frame and rear-axle conversions.)
* `footprint` — the rectangle a vehicle covers at a state.
* `DrivableArea` — the lanelets' union; how far a footprint reaches beyond it (off road, or off
  a route's lanes)."""

from __future__ import annotations

import math

import numpy as np
import shapely
from commonroad.scenario.lanelet import LaneletNetwork
from shapely.geometry import Polygon
from shapely.ops import unary_union

from simgap.trajectory import State


class PathFrame:
    """The Frenet frame of a polyline: its cumulative arc length, and the projection of points
    onto it."""

    def __init__(self, xy: np.ndarray):
        xy = np.asarray(xy, dtype=float)
        keep = np.concatenate([[True], np.hypot(*np.diff(xy, axis=0).T) > 1e-9])
        self.xy = xy[keep]
        if len(self.xy) < 2:
            raise ValueError("a reference path needs at least two distinct points")
        seg = np.diff(self.xy, axis=0)
        self._seg = seg
        self._seg_len = np.hypot(seg[:, 0], seg[:, 1])
        self.s = np.concatenate([[0.0], np.cumsum(self._seg_len)])

    @property
    def length(self) -> float:
        return float(self.s[-1])

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(s, d) of each point; the nearest segment wins (beyond the ends the path is extended)."""
        pts = np.atleast_2d(np.asarray(points, dtype=float))
        a = self.xy[:-1]
        rel = pts[:, None, :] - a[None, :, :]                      # (n, m, 2)
        u = np.einsum("nmk,mk->nm", rel, self._seg) / self._seg_len**2
        u_clamped = np.clip(u, 0.0, 1.0)
        # let the first and last segments extend beyond the ends of the path
        u_clamped[:, 0] = np.minimum(u[:, 0], 1.0)
        u_clamped[:, -1] = np.maximum(u[:, -1], 0.0)
        foot = a[None, :, :] + u_clamped[..., None] * self._seg[None, :, :]
        dist2 = np.sum((pts[:, None, :] - foot) ** 2, axis=2)
        j = np.argmin(dist2, axis=1)
        idx = np.arange(len(pts))
        s = self.s[j] + u_clamped[idx, j] * self._seg_len[j]
        cross = self._seg[j, 0] * rel[idx, j, 1] - self._seg[j, 1] * rel[idx, j, 0]
        d = np.sign(cross) * np.sqrt(dist2[idx, j])
        return s, d


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
