"""The geometry of a plan as a tracking controller sees it.

A plan is a time-stamped sequence of centre states. A controller tracks one reference point of
the vehicle (rear axle, centre, front axle); `PlannedPath` is the polyline that point of the
vehicle would draw if the plan were driven exactly, with arc length, projection of a measured
point (cross-track error), look-ahead points, and the plan's other quantities interpolated at the
projection. Beyond its ends the path continues straight along its end tangents, so a plan
shorter than a look-ahead distance, or a vehicle slightly behind the plan's first state,
still gets a well-defined reference.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from simgap.polyline import Polyline
from simgap.trajectory import Trajectory, wrap_angle
from simgap.vehicles.reference_points import along_heading

_MIN_SEGMENT = 1e-6   # m; shorter plan segments are standstill, their direction is the yaw
_MIN_CURVATURE_DS = 1e-2  # m; below this the curvature comes from the planned steering angle


@dataclass(frozen=True)
class Projection:
    """Where a measured point lies relative to a `PlannedPath`."""

    s: float          # arc length of the foot point [m] (< 0 before the start, > length after)
    lateral: float    # signed distance, > 0 when the point is left of the path [m]
    index: float      # fractional plan index of the foot point, clamped to [0, n-1]
    heading: float    # path tangent at the foot point [rad]


class PlannedPath:
    """The polyline drawn by a reference point ``offset`` metres ahead of the centre: a
    `simgap.polyline.Polyline` (``polyline``: its segments and arc length ``s``), continued
    straight beyond its ends along end tangents that follow the plan's heading, and the plan's
    quantities at a fractional plan index."""

    def __init__(self, plan: Trajectory, offset: float = 0.0, *, wheelbase: float,
                 rear_axle_to_center: float):
        self.plan = plan
        self.offset = float(offset)
        self.wheelbase = float(wheelbase)
        yaw = np.unwrap(np.asarray(plan.yaw, dtype=float))
        self._yaw = yaw
        self.x = plan.x + offset * np.cos(yaw)
        self.y = plan.y + offset * np.sin(yaw)
        n = len(plan)
        self.n = n
        self.polyline = Polyline(np.column_stack([self.x, self.y]))
        dx, dy = self.polyline.seg[:, 0], self.polyline.seg[:, 1]
        seg_len = self.polyline.seg_len
        moving = seg_len > _MIN_SEGMENT
        mid_yaw = 0.5 * (yaw[:-1] + yaw[1:])
        safe = np.where(moving, seg_len, 1.0)
        self._ux = np.where(moving, dx / safe, np.cos(mid_yaw))
        self._uy = np.where(moving, dy / safe, np.sin(mid_yaw))
        self._seg_len = seg_len
        self.s = self.polyline.s
        self.length = self.polyline.length
        # End tangents: chord direction corrected by half the heading change over the chord
        # (exact on a circular arc); the plan's yaw when the end segment is standstill.
        if n >= 2 and moving[0]:
            a0 = math.atan2(dy[0], dx[0]) - 0.5 * (yaw[1] - yaw[0])
        else:
            a0 = float(yaw[0])
        if n >= 2 and moving[-1]:
            a1 = math.atan2(dy[-1], dx[-1]) + 0.5 * (yaw[-1] - yaw[-2])
        else:
            a1 = float(yaw[-1])
        self._start_dir = (math.cos(a0), math.sin(a0), a0)
        self._end_dir = (math.cos(a1), math.sin(a1), a1)
        self.curvature = plan_curvature(plan, wheelbase=wheelbase,
                                        rear_axle_to_center=rear_axle_to_center)

    # --- interpolation of plan quantities -------------------------------------------------
    def value(self, column: str, index: float) -> float:
        """A plan column (or ``curvature``) at a fractional plan index (clamped)."""
        if column == "yaw":
            return wrap_angle(self._interp(self._yaw, index))
        if column == "curvature":
            return self._interp(self.curvature, index)
        return self._interp(np.asarray(getattr(self.plan, column)), index)

    def _interp(self, arr: np.ndarray, index: float) -> float:
        if self.n == 1 or index <= 0:
            return float(arr[0])
        if index >= self.n - 1:
            return float(arr[-1])
        k = int(index)
        w = index - k
        return float((1.0 - w) * arr[k] + w * arr[k + 1])

    def index_at_time(self, t: float) -> float:
        if self.n == 1:
            return 0.0
        return float(min(max((t - self.plan.t[0]) / self.plan.dt, 0.0), self.n - 1))

    def s_at_index(self, index: float) -> float:
        return self._interp(self.s, index)

    def index_at_s(self, s: float) -> float:
        if self.n == 1 or s <= 0:
            return 0.0
        if s >= self.length:
            return float(self.n - 1)
        k = int(np.searchsorted(self.s, s, side="right") - 1)
        k = min(max(k, 0), self.n - 2)
        seg = self._seg_len[k]
        return k + (0.0 if seg <= _MIN_SEGMENT else (s - self.s[k]) / seg)

    # --- geometry -------------------------------------------------------------------------
    def point_at(self, s: float) -> tuple[float, float]:
        """The point at arc length ``s``, on the straight extensions beyond the ends."""
        if s <= 0.0 or self.n == 1:
            cx, cy, _ = self._start_dir if s <= 0.0 else self._end_dir
            return float(self.x[0] + s * cx), float(self.y[0] + s * cy)
        if s >= self.length:
            cx, cy, _ = self._end_dir
            ds = s - self.length
            return float(self.x[-1] + ds * cx), float(self.y[-1] + ds * cy)
        k = int(np.searchsorted(self.s, s, side="right") - 1)
        k = min(max(k, 0), self.n - 2)
        d = s - self.s[k]
        return float(self.x[k] + d * self._ux[k]), float(self.y[k] + d * self._uy[k])

    def project(self, px: float, py: float) -> Projection:
        """Foot point of ``(px, py)`` on the path (segments plus the two straight extensions)."""
        best_d2 = math.inf
        best: tuple[float, float, float, float, float] | None = None  # s, idx, fx, fy, heading
        if self.n >= 2:
            rx = px - self.x[:-1]
            ry = py - self.y[:-1]
            along = np.clip(rx * self._ux + ry * self._uy, 0.0, self._seg_len)
            fx = self.x[:-1] + along * self._ux
            fy = self.y[:-1] + along * self._uy
            d2 = (px - fx) ** 2 + (py - fy) ** 2
            k = int(np.argmin(d2))
            best_d2 = float(d2[k])
            seg = self._seg_len[k]
            frac = float(along[k] / seg) if seg > _MIN_SEGMENT else 0.0
            heading = self.value("yaw", k + frac) if seg <= _MIN_SEGMENT else math.atan2(
                self._uy[k], self._ux[k])
            best = (float(self.s[k] + along[k]), k + frac, float(fx[k]), float(fy[k]), heading)
        # before the start
        cx, cy, a0 = self._start_dir
        back = (px - self.x[0]) * cx + (py - self.y[0]) * cy
        if back < 0.0 or self.n == 1:
            fx0, fy0 = self.x[0] + back * cx, self.y[0] + back * cy
            d2 = (px - fx0) ** 2 + (py - fy0) ** 2
            if d2 < best_d2 or best is None:
                best_d2, best = d2, (float(back), 0.0, float(fx0), float(fy0), a0)
        # after the end
        if self.n >= 2:
            cx, cy, a1 = self._end_dir
            fwd = (px - self.x[-1]) * cx + (py - self.y[-1]) * cy
            if fwd > 0.0:
                fx1, fy1 = self.x[-1] + fwd * cx, self.y[-1] + fwd * cy
                d2 = (px - fx1) ** 2 + (py - fy1) ** 2
                if d2 < best_d2:
                    best_d2, best = d2, (self.length + float(fwd), float(self.n - 1),
                                         float(fx1), float(fy1), a1)
        assert best is not None
        s, idx, fx, fy, heading = best
        lateral = math.cos(heading) * (py - fy) - math.sin(heading) * (px - fx)
        return Projection(s=s, lateral=float(lateral), index=float(idx), heading=float(heading))


def plan_curvature(plan: Trajectory, *, wheelbase: float, rear_axle_to_center: float
                   ) -> np.ndarray:
    """Path curvature [1/m] at each plan state, as the rear axle sees it (``tan(steer) / L``
    for a kinematic vehicle): heading change over rear-axle arc length, averaged over the two
    segments around a state. Where the rear axle hardly moves (standstill) the planned
    steering angle gives it instead."""
    n = len(plan)
    steer_kappa = np.tan(np.asarray(plan.steer, dtype=float)) / wheelbase
    if n == 1:
        return steer_kappa.copy()
    yaw = np.unwrap(np.asarray(plan.yaw, dtype=float))
    rx, ry = along_heading(plan.x, plan.y, yaw, -rear_axle_to_center)
    ds = np.hypot(np.diff(rx), np.diff(ry))
    dyaw = np.diff(yaw)
    seg_steer = 0.5 * (steer_kappa[:-1] + steer_kappa[1:])
    ok = ds > _MIN_CURVATURE_DS
    seg_kappa = np.where(ok, dyaw / np.where(ok, ds, 1.0), seg_steer)
    kappa = np.empty(n)
    kappa[0] = seg_kappa[0]
    kappa[-1] = seg_kappa[-1]
    if n > 2:
        kappa[1:-1] = 0.5 * (seg_kappa[:-1] + seg_kappa[1:])
    return kappa
