"""The planner's Frenet frame on the frenetix core, and the conversions at its edge.

Three conventions meet here and nowhere else:

* simgap's `State`: world frame, vehicle centre.
* the frenetix core: positions of the rear axle (where the kinematic bicycle's path tangent is
  the vehicle's heading), in a *local planning frame* - the world translated to the reference
  path's first point and rotated so that the path's headings stay well inside (-pi, pi]; the
  core's yaw-rate check differences wrapped headings and would reject every plan across +-pi.
* curvilinear coordinates (s, d) along the reference path.

The core's coordinate-system wrapper derives the reference heading from segment directions,
which in a curve lags half a segment behind (0.05 rad on a 10 m radius at 1 m spacing), and its
sample filler writes heading = atan(d') instead of atan(d' / (1 - kappa_r d)). Both would leave
the planned heading off the direction of motion. The frame therefore overwrites the wrapper's
heading and curvature tables with the smooth reference path's, and `cartesian` recomputes
heading, curvature, speed and acceleration of samples with the exact Frenet relations.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import frenetix
import numpy as np

from simgap.planning.reference_path import ReferencePath
from simgap.polyline import Polyline
from simgap.trajectory import wrap_angle

_EPS_SPEED = 1e-3
# The core's sample filler (FillCoordinates) evaluates the polynomials with a nested Horner
# scheme whose second accumulator is P''(t)/2, so the curvilinear s_ddot and d_ddot it stores -
# and the Cartesian acceleration and curvature it derives from them - are off. Its cost terms on
# jerk use the coefficients and are right. We restore the factor when converting samples.
SECOND_DERIVATIVE_FIX = 2.0


@dataclass(frozen=True)
class CartesianBatch:
    """Samples in the local frame, rear-axle reference: arrays of shape (samples, steps), and
    each sample's row of the sampling matrix (samples, 13)."""

    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    v: np.ndarray
    a: np.ndarray
    kappa: np.ndarray
    s: np.ndarray
    d: np.ndarray
    parameters: np.ndarray


class FrenetFrame:
    """Local planning frame + frenetix curvilinear coordinate system of a `ReferencePath`."""

    def __init__(self, reference: ReferencePath):
        self.reference = reference
        self.origin = reference.xy[0].copy()
        # rotate so that the path's headings are centred on 0
        self.rotation = 0.5 * float(reference.theta.min() + reference.theta.max())
        self.heading_span = float(reference.theta.max() - reference.theta.min())
        c, s = math.cos(self.rotation), math.sin(self.rotation)
        self._r_world_to_local = np.array([[c, s], [-s, c]])
        local_xy = self.points_to_local(reference.xy)
        self.core = frenetix.CoordinateSystemWrapper(np.ascontiguousarray(local_xy))
        self._align_tables(local_xy)

    # -- frames ------------------------------------------------------------------------------
    def points_to_local(self, xy: np.ndarray) -> np.ndarray:
        return (np.asarray(xy, dtype=float) - self.origin) @ self._r_world_to_local.T

    def xy_to_local(self, x, y):
        dx, dy = np.asarray(x, dtype=float) - self.origin[0], np.asarray(y, dtype=float) - self.origin[1]
        c, s = math.cos(self.rotation), math.sin(self.rotation)
        return c * dx + s * dy, -s * dx + c * dy

    def xy_to_world(self, x, y):
        c, s = math.cos(self.rotation), math.sin(self.rotation)
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        return c * x - s * y + self.origin[0], s * x + c * y + self.origin[1]

    # -- reference tables --------------------------------------------------------------------
    def _align_tables(self, local_xy: np.ndarray) -> None:
        """Give the core the smooth path's heading and curvature at its own vertices.

        The core's polyline is ours with a few points (1e-4 m apart) added at each end; its arc
        length starts at its first point. ``s_offset`` maps our arc length onto the core's.
        """
        ref = self.reference
        line = np.asarray(self.core.ref_line)
        pos = np.asarray(self.core.ref_pos)
        core_line = Polyline(line, pos)         # the core's arc length along its own polyline
        first = core_line.nearest(local_xy[0])
        self.s_offset = float(pos[first])
        s_ours = pos - self.s_offset
        theta = ref.polyline.interpolate(ref.theta, s_ours) - self.rotation
        kappa = ref.polyline.interpolate(ref.kappa, s_ours)
        kappa_d = np.gradient(kappa, pos) if len(pos) > 2 else np.zeros_like(kappa)
        kappa_dd = np.gradient(kappa_d, pos) if len(pos) > 2 else np.zeros_like(kappa)
        self.core.ref_theta = theta
        self.core.ref_curv = kappa
        self.core.ref_curv_d = kappa_d
        self.core.ref_curv_dd = kappa_dd
        self._pos, self._theta, self._kappa, self._kappa_d = pos, theta, kappa, kappa_d
        self._core_line = core_line
        self.s_min, self.s_max = float(pos[0]), float(pos[-1])

    def reference_tables(self) -> tuple[np.ndarray, np.ndarray]:
        """The core's arc length at its vertices and the curvature it holds there."""
        return self._pos, self._kappa

    def reference_at(self, s_core: np.ndarray):
        """Local heading, curvature and its derivative of the reference at core arc lengths."""
        line = self._core_line
        return (line.interpolate(self._theta, s_core), line.interpolate(self._kappa, s_core),
                line.interpolate(self._kappa_d, s_core))

    def curvilinear_to_local(self, s_core: np.ndarray, d: np.ndarray):
        """Local (x, y, heading) of points at curvilinear (s, d), heading parallel to the path."""
        x, y = self._core_line.point_at(s_core)
        theta = self._core_line.interpolate(self._theta, s_core)
        return x - d * np.sin(theta), y + d * np.cos(theta), theta

    def to_reference_s(self, s_core):
        """Core arc length → the `ReferencePath`'s arc length."""
        return np.asarray(s_core) - self.s_offset

    # -- the initial state -------------------------------------------------------------------
    def initial_state(self, x_rear: float, y_rear: float, yaw: float, v: float, a: float,
                      steer: float, wheelbase: float, low_velocity: bool):
        """Project a rear-axle state (local frame) into the Frenet frame: (x0_lon, x0_lat).

        Raises RuntimeError when the core cannot project it (too far from the path, or heading
        against the path's direction).
        """
        x0 = frenetix.CartesianPlannerState(np.array([x_rear, y_rear]), float(yaw), float(v),
                                            float(a), float(steer))
        cl = frenetix.compute_initial_state(coordinate_system=self.core, x_0=x0, wheelbase=wheelbase,
                                            low_velocity_mode=low_velocity)
        lon, lat = np.array(cl.x0_lon, dtype=float), np.array(cl.x0_lat, dtype=float)
        if not (np.all(np.isfinite(lon)) and np.all(np.isfinite(lat))):
            raise RuntimeError("the initial state does not project onto the reference path")
        return lon, lat

    def local_heading(self, yaw_world: float) -> float:
        return wrap_angle(yaw_world - self.rotation)

    # -- samples → Cartesian -----------------------------------------------------------------
    def cartesian(self, samples, low_velocity: bool, yaw0: float) -> CartesianBatch:
        """Exact Cartesian motion (rear axle, local frame) of frenetix samples.

        Positions are the core's; heading, curvature, speed and acceleration follow from the
        curvilinear derivatives with the exact relations (Werling et al. 2010). Where a sample
        stands still (not in low-velocity mode) the heading is held, starting from ``yaw0``.
        """
        cart = [t.cartesian for t in samples]
        curv = [t.curvilinear for t in samples]
        x = np.array([c.x for c in cart])
        y = np.array([c.y for c in cart])
        s = np.array([c.s for c in curv])
        d = np.array([c.d for c in curv])
        dd = np.array([c.d_dot for c in curv])
        ss = np.array([c.s_dot for c in curv])
        # frenetix 0.4.0 fills second derivatives from a Horner scheme that yields P''/2
        ddd = SECOND_DERIVATIVE_FIX * np.array([c.d_ddot for c in curv])
        sss = SECOND_DERIVATIVE_FIX * np.array([c.s_ddot for c in curv])
        theta_r, k_r, k_r_d = self.reference_at(s)
        moving = ss > _EPS_SPEED
        if low_velocity:
            d1, d2 = dd, ddd
        else:
            safe = np.where(moving, ss, 1.0)
            d1 = np.where(moving, dd / safe, 0.0)
            d2 = np.where(moving, (ddd - d1 * sss) / safe**2, 0.0)
        q = 1.0 - k_r * d
        q = np.where(q > 1e-3, q, 1e-3)
        dtheta = np.arctan2(d1, q)
        cos_t, tan_t = np.cos(dtheta), np.tan(dtheta)
        kappa = ((d2 + (k_r_d * d + k_r * d1) * tan_t) * cos_t**2 / q + k_r) * cos_t / q
        v = ss * q / cos_t
        dtheta_ds = kappa * q / cos_t - k_r
        a = sss * q / cos_t + ss**2 / cos_t * (q * tan_t * dtheta_ds - (k_r_d * d + k_r * d1))
        yaw = theta_r + dtheta
        if not low_velocity and not moving.all():
            # hold the heading where the sample stands still
            yaw = yaw.copy()
            yaw[:, 0] = np.where(moving[:, 0], yaw[:, 0], yaw0)
            for k in range(1, yaw.shape[1]):
                yaw[:, k] = np.where(moving[:, k], yaw[:, k], yaw[:, k - 1])
        parameters = np.array([t.sampling_parameters for t in samples])
        return CartesianBatch(x, y, yaw, v, a, kappa, s, d, parameters)
