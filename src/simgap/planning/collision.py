"""Collision checks of sampled plans: against the road's edge and against other traffic.

Both work on whole batches of plans at once (arrays of shape (plans, steps)) in the planner's
local frame, so that the planner can test candidates in cost order, a few at a time.

* Road: the footprint (the vehicle's rectangle at each state) must stay on the drivable area -
  the union of the lanelets, continued straight beyond the route's dead end so that a plan may
  run past the goal. The area is rasterised once per agent and eroded by one cell plus the
  margin; a footprint is on the road when points along its outline (``point_spacing`` apart)
  all fall on drivable cells. Two wider bands are kept for a vehicle that is not on those cells
  now (`RoadBand`): the road without the margin, and the cells the road touches (a footprint off
  them is off the road for sure). Lookups are plain array indexing, about 10 ns per point.
* Traffic: oriented-box separating-axis tests between the ego footprint and every participant's
  predicted footprint at the same instants (a bounding-circle test first).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from enum import IntEnum

import numpy as np
from commonroad.scenario.lanelet import LaneletNetwork
from PIL import Image, ImageDraw
from scipy import ndimage

from simgap.planning.protocol import TrafficParticipant


def footprint_outline(length: float, width: float, spacing: float) -> np.ndarray:
    """Points along a centred length x width rectangle's outline (corners included), (n, 2)."""
    hl, hw = length / 2.0, width / 2.0
    n_long = max(1, int(math.ceil(length / spacing)))
    n_short = max(1, int(math.ceil(width / spacing)))
    along = np.linspace(-hl, hl, n_long + 1)
    across = np.linspace(-hw, hw, n_short + 1)[1:-1]
    pts = [np.stack([along, np.full_like(along, hw)], 1), np.stack([along, np.full_like(along, -hw)], 1),
           np.stack([np.full_like(across, hl), across], 1), np.stack([np.full_like(across, -hl), across], 1)]
    return np.vstack(pts)


def _dead_end_extensions(network: LaneletNetwork, near: np.ndarray, length: float,
                         radius: float = 12.0) -> list[np.ndarray]:
    """Rectangles continuing the lanelets that end (or begin) without a successor (predecessor)
    near the point ``near``: the road is assumed to go on straight beyond the scenario's end."""
    polygons = []
    for lanelet in network.lanelets:
        left, right, centre = lanelet.left_vertices, lanelet.right_vertices, lanelet.center_vertices
        ends = []
        if not lanelet.successor:
            ends.append((left[-1], right[-1], centre[-1] - centre[-2]))
        if not lanelet.predecessor:
            ends.append((left[0], right[0], centre[0] - centre[1]))
        for a, b, direction in ends:
            if np.linalg.norm(0.5 * (a + b) - near) > radius:
                continue
            u = direction / max(np.linalg.norm(direction), 1e-9)
            polygons.append(np.array([a, b, b + length * u, a + length * u]))
    return polygons


class RoadBand(IntEnum):
    """How far out a point may be, from the narrowest band to the widest."""

    SAFE = 0        # on the road, the margin away from its edge
    ROAD = 1        # on the road (eroded by one cell: the drawing's own error)
    TOUCHED = 2     # on a cell the road touches: within a cell of the road


class DrivableAreaGrid:
    """The drivable area as boolean grids in a local frame, one per `RoadBand`."""

    def __init__(self, polygons: Sequence[np.ndarray], bounds: tuple[float, float, float, float],
                 resolution: float, margin: float = 0.0, max_cells: int = 30_000_000):
        x0, y0, x1, y1 = bounds
        area = max((x1 - x0) * (y1 - y0), 1e-6)
        if area / resolution**2 > max_cells:
            resolution = math.sqrt(area / max_cells)
        self.resolution = resolution
        self.x0, self.y0 = x0, y0
        nx = int(math.ceil((x1 - x0) / resolution)) + 1
        ny = int(math.ceil((y1 - y0) / resolution)) + 1
        image = Image.new("1", (nx, ny), 0)
        draw = ImageDraw.Draw(image)
        for poly in polygons:
            px = (poly[:, 0] - x0) / resolution - 0.5
            py = (poly[:, 1] - y0) / resolution - 0.5
            draw.polygon(list(zip(px.tolist(), py.tolist())), fill=1, outline=1)
        mask = np.array(image, dtype=bool)
        # drawing fills cells the outline touches: erode by one cell, plus the margin
        square = np.ones((3, 3), dtype=bool)
        road = ndimage.binary_erosion(mask, structure=square, iterations=1, border_value=0)
        margin_cells = int(math.ceil(margin / resolution))
        safe = ndimage.binary_erosion(road, structure=square, iterations=margin_cells,
                                      border_value=0) if margin_cells else road
        self.bands = (safe, road, mask)
        self.cells = safe
        self.shape = safe.shape

    @classmethod
    def for_route(cls, network: LaneletNetwork, to_local, route_end: np.ndarray, corridor_xy: np.ndarray,
                  extension_m: float, corridor_margin: float, resolution: float, margin: float,
                  max_cells: int) -> DrivableAreaGrid:
        """Grid of all lanelets (and the dead-end extensions near ``route_end``) over the bounding
        box of ``corridor_xy`` (local frame) grown by ``corridor_margin``. ``to_local`` maps world
        points (n, 2) into the local frame."""
        polygons = [to_local(np.asarray(l.polygon.vertices, dtype=float)) for l in network.lanelets]
        polygons += [to_local(p) for p in _dead_end_extensions(network, route_end, extension_m)]
        lo = corridor_xy.min(axis=0) - corridor_margin
        hi = corridor_xy.max(axis=0) + corridor_margin
        return cls(polygons, (lo[0], lo[1], hi[0], hi[1]), resolution, margin, max_cells)

    def contains(self, x: np.ndarray, y: np.ndarray, band: RoadBand = RoadBand.SAFE) -> np.ndarray:
        """True where a point lies in ``band`` (by default: safely on the road); points off the
        grid are off the road."""
        ix = np.floor((x - self.x0) / self.resolution).astype(np.int64)
        iy = np.floor((y - self.y0) / self.resolution).astype(np.int64)
        inside = (ix >= 0) & (iy >= 0) & (ix < self.shape[1]) & (iy < self.shape[0])
        out = np.zeros(ix.shape, dtype=bool)
        out[inside] = self.bands[band][iy[inside], ix[inside]]
        return out


def footprints_on_road(grid: DrivableAreaGrid, outline: np.ndarray, cx: np.ndarray, cy: np.ndarray,
                       yaw: np.ndarray, band: RoadBand = RoadBand.SAFE) -> np.ndarray:
    """(plans, steps) booleans: is the footprint centred at (cx, cy) with heading ``yaw`` in ``band``
    (by default: safely on the road)."""
    c, s = np.cos(yaw)[..., None], np.sin(yaw)[..., None]
    px = cx[..., None] + c * outline[:, 0] - s * outline[:, 1]
    py = cy[..., None] + s * outline[:, 0] + c * outline[:, 1]
    return grid.contains(px, py, band).all(axis=-1)


@dataclass(frozen=True)
class TrafficPrediction:
    """Participants' centre poses at the plan's instants (local frame), shapes (participants, steps)."""

    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    half_length: np.ndarray   # (participants,)
    half_width: np.ndarray
    v_end: np.ndarray | None = None   # (participants,) speed at the last instant

    @property
    def empty(self) -> bool:
        return len(self.half_length) == 0

    def braking_from_end(self, steps: int, dt: float, deceleration: float | None) -> TrafficPrediction:
        """Beyond the last instant, ``steps`` more: every participant brakes to standstill along its
        last heading at ``deceleration`` (None: stands where it is at the last instant)."""
        tile = lambda a: np.repeat(a[:, -1:], steps, axis=1)  # noqa: E731
        x, y, yaw = tile(self.x), tile(self.y), tile(self.yaw)
        if deceleration is not None and self.v_end is not None and steps > 0:
            v = np.maximum(self.v_end, 0.0)[:, None]
            tt = np.minimum(dt * np.arange(1, steps + 1)[None, :], v / deceleration)
            travel = v * tt - 0.5 * deceleration * tt**2
            x, y = x + travel * np.cos(yaw), y + travel * np.sin(yaw)
        return TrafficPrediction(x, y, yaw, self.half_length, self.half_width, self.v_end)


def predict_traffic(traffic: Sequence[TrafficParticipant], times: np.ndarray, to_local_xy,
                    rotation: float, margin: float) -> TrafficPrediction:
    """Each participant's prediction sampled at ``times``: linear interpolation inside the
    prediction, absent (NaN) before it, and constant speed along its last heading after it.
    Footprints are grown by ``margin`` on every side."""
    rows = []
    for tp in traffic:
        pred = tp.prediction
        t = np.asarray(pred.t)
        yaw_u = np.unwrap(np.asarray(pred.yaw))
        tt = np.clip(times, t[0], t[-1])
        x = np.interp(tt, t, pred.x)
        y = np.interp(tt, t, pred.y)
        absent = times < t[0] - 1e-9          # not in the scene yet (a recording that starts later)
        if absent.any():
            x, y = np.where(absent, np.nan, x), np.where(absent, np.nan, y)
        yaw = np.interp(tt, t, yaw_u)
        beyond = np.maximum(times - t[-1], 0.0)
        v_last = float(pred.v[-1])
        x = x + beyond * v_last * math.cos(yaw_u[-1])
        y = y + beyond * v_last * math.sin(yaw_u[-1])
        lx, ly = to_local_xy(x, y)
        v_end = v_last if beyond[-1] > 0 else float(np.interp(times[-1], t, pred.v))
        rows.append((lx, ly, yaw - rotation, tp.length / 2 + margin, tp.width / 2 + margin, v_end))
    if not rows:
        z = np.zeros((0, len(times)))
        return TrafficPrediction(z, z, z, np.zeros(0), np.zeros(0), np.zeros(0))
    columns = [np.array([r[k] for r in rows]) for k in range(6)]
    return TrafficPrediction(*columns)


def traffic_collisions(cx: np.ndarray, cy: np.ndarray, yaw: np.ndarray, half_length: float,
                       half_width: float, traffic: TrafficPrediction) -> np.ndarray:
    """(plans, steps) booleans: does the ego box overlap any participant's box at that step."""
    overlaps = traffic_overlaps(cx, cy, yaw, half_length, half_width, traffic)
    return overlaps.any(axis=-1) if overlaps is not None else np.zeros(cx.shape, dtype=bool)


def traffic_overlaps(cx: np.ndarray, cy: np.ndarray, yaw: np.ndarray, half_length: float,
                     half_width: float, traffic: TrafficPrediction) -> np.ndarray | None:
    """(plans, steps, participants) booleans: does the ego box overlap that participant's box at that
    step (None: nothing comes near). A participant not in the scene at a step (NaN pose) overlaps nothing."""
    if traffic.empty:
        return None
    # (plans, steps, participants)
    dx = traffic.x.T[None] - cx[..., None]
    dy = traffic.y.T[None] - cy[..., None]
    hl2, hw2 = traffic.half_length[None, None, :], traffic.half_width[None, None, :]
    reach = math.hypot(half_length, half_width) + np.hypot(hl2, hw2)
    near = dx * dx + dy * dy <= reach * reach
    if not near.any():
        return None
    return near & boxes_overlap(dx, dy, yaw[..., None], half_length, half_width, traffic.yaw.T[None], hl2, hw2)


def boxes_overlap(dx, dy, yaw_a, half_length_a, half_width_a, yaw_b, half_length_b, half_width_b) -> np.ndarray:
    """Whether box B, its centre (dx, dy) from box A's, overlaps box A: separating axes, broadcast
    over any shapes (a NaN offset overlaps nothing)."""
    c1, s1, c2, s2 = np.cos(yaw_a), np.sin(yaw_a), np.cos(yaw_b), np.sin(yaw_b)
    cos_rel = np.abs(c1 * c2 + s1 * s2)          # |u_a.u_b| = |v_a.v_b|
    sin_rel = np.abs(s1 * c2 - c1 * s2)          # |u_a.v_b| = |v_a.u_b|
    return ((np.abs(dx * c1 + dy * s1) <= half_length_a + half_length_b * cos_rel + half_width_b * sin_rel)
            & (np.abs(-dx * s1 + dy * c1) <= half_width_a + half_length_b * sin_rel + half_width_b * cos_rel)
            & (np.abs(dx * c2 + dy * s2) <= half_length_b + half_length_a * cos_rel + half_width_a * sin_rel)
            & (np.abs(-dx * s2 + dy * c2) <= half_width_b + half_length_a * sin_rel + half_width_a * cos_rel))


def struck_from_behind(cx: np.ndarray, cy: np.ndarray, yaw: np.ndarray, half_length: float,
                       traffic: TrafficPrediction) -> np.ndarray:
    """(plans, steps, participants) booleans: the participant is behind the ego (its centre more than
    half the ego's length behind the ego's centre, along the ego's heading) and heads its way (within
    60 degrees): an overlap with it is that participant running into the ego, not the ego's doing."""
    dx = traffic.x.T[None] - cx[..., None]
    dy = traffic.y.T[None] - cy[..., None]
    c1, s1 = np.cos(yaw)[..., None], np.sin(yaw)[..., None]
    yaw2 = traffic.yaw.T[None]
    ahead = dx * c1 + dy * s1
    aligned = c1 * np.cos(yaw2) + s1 * np.sin(yaw2)
    return (ahead < -half_length) & (aligned > 0.5)
