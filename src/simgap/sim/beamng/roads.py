"""The CommonRoad road network as BeamNG decal roads.

Every lanelet becomes one decal road along its centre line, with the lanelet's width at each
node and the asphalt material; every marked bound (solid, dashed, broad, double, kerb) becomes a
decal road of its own, drawn over the asphalt. Junction lanelets are lanelets like any other.

BeamNG interpolates a decal road between its nodes with a spline and builds the road's edges
from each node's neighbours. Too few nodes on a tight curve cut the corner (the road loses its
shape); nodes much closer than the road is wide make neighbouring cross-sections overlap (the
road flips). Nodes are therefore placed where a straight line from the last node would stray
more than ``shape_tolerance`` from the lanelet (2 cm by default), but never closer than
``min_spacing`` (nor than half the road's width) and never further apart than ``max_spacing``;
the lanelet's first and last points are always nodes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from commonroad.scenario.lanelet import LaneletNetwork

from simgap.polyline import arc_length
from simgap.scenario.markings import CURB_WIDTH, marking_lines
from simgap.sim.beamng.settings import Materials

ROAD_PRIORITY, MARKING_PRIORITY = 10, 9        # BeamNG draws lower render priorities on top


@dataclass(frozen=True)
class DecalRoad:
    """One BeamNG decal road: nodes are (x, y, z, width) in metres."""

    rid: str
    material: str
    nodes: tuple[tuple[float, float, float, float], ...]
    drivable: bool
    render_priority: int
    kind: str                  # "lanelet" | "marking" | "curb"


def node_indices(xy: np.ndarray, width: float, tolerance: float, min_spacing: float,
                 max_spacing: float) -> list[int]:
    """Indices of the points of polyline ``xy`` kept as road nodes (see the module doc): a
    node is added where the straight line from the last node would leave the polyline by more
    than ``tolerance``, no closer than the floor and no further than ``max_spacing``."""
    n = len(xy)
    if n <= 2:
        return list(range(n))
    s = arc_length(xy, by_norm=True)
    floor = max(min_spacing, 0.5 * width)
    keep = [0]
    for i in range(1, n - 1):
        since = s[i + 1] - s[keep[-1]]
        if since > max_spacing or (since >= floor and _deviation(xy, keep[-1], i + 1) > tolerance):
            keep.append(i)
    if (s[-1] - s[keep[-1]] < floor and len(keep) > 1 and s[-1] - s[keep[-2]] <= max_spacing
            and _deviation(xy, keep[-2], n - 1) <= tolerance):
        keep.pop()                      # the last point replaces a node just before it
    keep.append(n - 1)
    return keep


def _deviation(xy: np.ndarray, i: int, j: int) -> float:
    """Largest distance of the points between ``i`` and ``j`` from the chord ``xy[i]``-``xy[j]``."""
    if j - i < 2:
        return 0.0
    a, b = xy[i], xy[j]
    d = b - a
    length = float(np.hypot(*d))
    if length < 1e-9:
        return float(np.max(np.linalg.norm(xy[i + 1:j] - a, axis=1)))
    rel = xy[i + 1:j] - a
    return float(np.max(np.abs(rel[:, 0] * d[1] - rel[:, 1] * d[0])) / length)


def _densify(xy: np.ndarray, step: float) -> np.ndarray:
    """``xy`` resampled every ``step`` metres or closer (keeps its own points' shape)."""
    s = arc_length(xy, by_norm=True)
    if s[-1] <= 0:
        return xy
    ss = np.unique(np.concatenate([s, np.linspace(0.0, s[-1], int(math.ceil(s[-1] / step)) + 1)]))
    ss = ss[np.concatenate([[True], np.diff(ss) > 1e-6])]      # no zero-length pieces: their heading is noise
    return np.column_stack([np.interp(ss, s, xy[:, 0]), np.interp(ss, s, xy[:, 1])])


def _nodes(xy: np.ndarray, widths: np.ndarray, z: float, tolerance: float, spacing: tuple[float, float]
           ) -> tuple[tuple[float, float, float, float], ...]:
    fine = _densify(xy, min(spacing[0], 0.5))
    fine_w = np.interp(arc_length(fine, by_norm=True), arc_length(xy, by_norm=True), widths)
    keep = node_indices(fine, float(np.max(widths)), tolerance, spacing[0], spacing[1])
    return tuple((float(fine[i, 0]), float(fine[i, 1]), z, float(fine_w[i])) for i in keep)


def decal_roads(network: LaneletNetwork, materials: Materials, shape_tolerance: float = 0.02,
                node_spacing: tuple[float, float] = (1.0, 10.0), z: float = 0.0) -> list[DecalRoad]:
    """The decal roads of ``network``: the lanelets first, then their markings and kerbs."""
    roads = []
    for lanelet in network.lanelets:
        centre = np.asarray(lanelet.center_vertices, dtype=float)
        widths = np.linalg.norm(np.asarray(lanelet.left_vertices, dtype=float)
                                - np.asarray(lanelet.right_vertices, dtype=float), axis=1)
        roads.append(DecalRoad(f"lanelet_{lanelet.lanelet_id}", materials.road,
                               _nodes(centre, widths, z, shape_tolerance, node_spacing), True, ROAD_PRIORITY, "lanelet"))
    for i, line in enumerate(marking_lines(network, curbs=True)):
        curb = line.marking in CURB_WIDTH
        material = materials.curb if curb else materials.dashed if line.dashed else materials.solid
        widths = np.full(len(line.xy), line.width)
        roads.append(DecalRoad(f"{'curb' if curb else 'marking'}_{i}", material,
                               _nodes(line.xy, widths, z, shape_tolerance, node_spacing), False, MARKING_PRIORITY,
                               "curb" if curb else "marking"))
    return roads

