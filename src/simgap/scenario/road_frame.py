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

from simgap.polyline import Polyline, without_duplicates
from simgap.trajectory import State


class PathFrame(Polyline):
    """The Frenet frame of a polyline (`simgap.polyline.Polyline`, repeated points dropped): its
    cumulative arc length ``s``, and the projection of points onto it as (s, d) (`project`)."""

    def __init__(self, xy: np.ndarray):
        xy = without_duplicates(np.asarray(xy, dtype=float), 1e-9)
        if len(xy) < 2:
            raise ValueError("a reference path needs at least two distinct points")
        super().__init__(xy)


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
