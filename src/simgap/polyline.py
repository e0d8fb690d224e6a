"""The polyline: points in the plane joined by straight segments, with their arc length, the
projection of points onto it as curvilinear (s, d), resampling, heading and curvature, and points
and values interpolated at an arc length.

Every path of simgap is built on it: a route's reference path (`planning.reference_path`), the
Frenet planner's frame on the frenetix core (`planning.frenet_frame`), the road frame of a lane's
centre line (`scenario.road_frame.PathFrame`), the path a tracking controller follows
(`control.planned_path`), drawn road markings (`sim.mujoco.road`, `sim.beamng.roads`).

It lives at the bottom of the layering, beside `simgap.trajectory` (numpy only, no simgap import;
in the import contract's layer of `files`, `trajectory` and `registry`): its users sit in `scenario`, `planning`,
`control` and `sim`, and `control` may import only the base and `vehicles` (docs/concepts/
architecture.md), so `scenario`, the lowest of the others, could not hold it - nor should a
polyline pull commonroad in through `simgap.scenario`'s package. (`simgap.scenario.geometry` is
another thing: a road's exact centre line from straights, arcs and clothoids.)

Each operation is written once and computed the same way everywhere (the arc length as the
cumulative sum of `np.hypot` of the segments, interpolation by `np.interp`), so that a path's
numbers do not depend on which class computed them, down to the last bit; the drawn roads keep the
measure they were built with (`arc_length`'s ``by_norm``).
"""

from __future__ import annotations

import numpy as np


def arc_length(xy: np.ndarray, *, by_norm: bool = False) -> np.ndarray:
    """Distance along the polyline ``xy`` (n, 2) to each of its points: (n,), from 0.

    ``by_norm``: each segment's length as `np.linalg.norm` computes it (the square root of the sum
    of squares, rounded twice) instead of `np.hypot` - how the drawn roads and markings
    (`sim.mujoco.road`, `sim.beamng.roads`) have always measured. The two differ in the last bit
    for about one segment in six; measured by hypot, drawn dashes and BeamNG's road nodes would move
    by up to 1e-13 m, so the worlds keep their measure and are built bit for bit as before."""
    if by_norm:
        return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))])
    return np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])


def without_duplicates(xy: np.ndarray, tolerance: float = 1e-6) -> np.ndarray:
    """``xy`` without the points that lie within ``tolerance`` of the point before them."""
    keep = np.concatenate([[True], np.hypot(*np.diff(xy, axis=0).T) > tolerance])
    return xy[keep]


def resample(xy: np.ndarray, step: float) -> np.ndarray:
    """The polyline ``xy`` at evenly spaced arc lengths, ``step`` apart or a little closer, both
    ends kept (at least two points)."""
    s = arc_length(xy)
    n = max(2, int(np.ceil(s[-1] / step)) + 1)
    grid = np.linspace(0.0, s[-1], n)
    return np.stack([np.interp(grid, s, xy[:, 0]), np.interp(grid, s, xy[:, 1])], axis=1)


def heading_and_curvature(xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Arc length, heading (unwrapped: continuous) and signed curvature (positive: turning left)
    at every point of a polyline, by central differences along its arc length."""
    s = arc_length(xy)
    theta = np.unwrap(np.arctan2(np.gradient(xy[:, 1], s), np.gradient(xy[:, 0], s)))
    return s, theta, np.gradient(theta, s)


def nearest(points: np.ndarray, point: np.ndarray) -> int:
    """The index of the row of ``points`` nearest ``point``."""
    return int(np.hypot(*(points - point).T).argmin())


def offset_polyline(xy: np.ndarray, d: float) -> np.ndarray:
    """The polyline moved ``d`` to its left (along the normals of its central-difference tangents)."""
    if d == 0.0:
        return xy
    tangent = np.gradient(xy, axis=0)
    tangent /= np.maximum(np.linalg.norm(tangent, axis=1, keepdims=True), 1e-12)
    return xy + d * np.column_stack([-tangent[:, 1], tangent[:, 0]])


class Polyline:
    """A polyline: its points ``xy`` (n, 2), segments ``seg`` (n-1, 2) and their lengths
    ``seg_len``, and the arc length ``s`` (n,) of each point from the first.

    ``s`` may be given: an arc length measured otherwise (the frenetix core's along its own copy
    of the line, a smoothed curve's); it is then taken as it is. One point is a polyline of
    length 0 (no segment); `project` needs distinct points (`without_duplicates`).
    """

    def __init__(self, xy: np.ndarray, s: np.ndarray | None = None):
        self.xy = np.asarray(xy, dtype=float)
        self.seg = np.diff(self.xy, axis=0)
        self.seg_len = np.hypot(self.seg[:, 0], self.seg[:, 1])
        self.s = np.concatenate([[0.0], np.cumsum(self.seg_len)]) if s is None else np.asarray(s, dtype=float)

    @property
    def length(self) -> float:
        return float(self.s[-1])

    def __len__(self) -> int:
        return len(self.xy)

    # -- along the line ----------------------------------------------------------------------
    def interpolate(self, values: np.ndarray, s: np.ndarray | float) -> np.ndarray:
        """``values`` (one per point) at arc lengths ``s``: linear between points, clamped at the ends."""
        return np.interp(s, self.s, values)

    def point_at(self, s: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """(x, y) at arc lengths ``s``: linear between points, clamped at the ends."""
        return np.interp(s, self.s, self.xy[:, 0]), np.interp(s, self.s, self.xy[:, 1])

    def resampled(self, step: float) -> Polyline:
        """The same line at evenly spaced arc lengths (`resample`)."""
        return Polyline(resample(self.xy, step))

    def heading_and_curvature(self) -> tuple[np.ndarray, np.ndarray]:
        """Heading (unwrapped) and signed curvature at every point (`heading_and_curvature`)."""
        _, theta, kappa = heading_and_curvature(self.xy)
        return theta, kappa

    def nearest(self, point: np.ndarray) -> int:
        """The index of the point nearest ``point``."""
        return nearest(self.xy, point)

    # -- onto the line -----------------------------------------------------------------------
    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Curvilinear (s, d) of each point: arc length of its foot point on the nearest segment
        and signed distance (positive to the left of the line's direction); beyond the ends the
        first and last segments are extended straight."""
        pts = np.atleast_2d(np.asarray(points, dtype=float))
        a = self.xy[:-1]
        rel = pts[:, None, :] - a[None, :, :]                      # (n, m, 2)
        u = np.einsum("nmk,mk->nm", rel, self.seg) / self.seg_len**2
        u_clamped = np.clip(u, 0.0, 1.0)
        # let the first and last segments extend beyond the ends of the path
        u_clamped[:, 0] = np.minimum(u[:, 0], 1.0)
        u_clamped[:, -1] = np.maximum(u[:, -1], 0.0)
        foot = a[None, :, :] + u_clamped[..., None] * self.seg[None, :, :]
        dist2 = np.sum((pts[:, None, :] - foot) ** 2, axis=2)
        j = np.argmin(dist2, axis=1)
        idx = np.arange(len(pts))
        s = self.s[j] + u_clamped[idx, j] * self.seg_len[j]
        cross = self.seg[j, 0] * rel[idx, j, 1] - self.seg[j, 1] * rel[idx, j, 0]
        d = np.sign(cross) * np.sqrt(dist2[idx, j])
        return s, d
