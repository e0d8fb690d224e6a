"""A lane-following Intelligent Driver Model planner, for traffic that is not under test.

It follows its route's centre line (simgap's reference path) and sets its speed with the IDM
(Treiber, Hennecke, Helbing 2000) towards whatever is ahead on that line in ``world.traffic``, and
towards the end of its route, where it stops. Every cycle starts from the observed state:

* longitudinal: arc length s and speed v integrated over the horizon with the IDM's acceleration;
  the free-road speed is simgap's speed profile a look-ahead ahead (the cruise speed, lowered for
  curvature and for the goal's velocity and time windows); the leader at each instant is the nearest participant
  whose predicted footprint overlaps the lane ahead (its speed taken along the path), or a
  standing obstacle at the route's end;
* lateral: the offset d from the centre line and its slope (the heading error) are brought to zero
  by a quartic in s over ``max(convergence_min_m, v * convergence_s)`` metres, so an off-centre
  start or a heading error joins the lane smoothly.

Why not `commonroad-idm-planner` 0.2.1: its `IDMPlanner` continues its own previous plan
(``plan()`` starts at the last planned state; ``re_plan`` needs a new PlanningProblem and recomputes
its velocity profile), snaps every planned position onto the reference path's points (an
off-centre or mis-headed observed state jumps onto the centre line in one step, and positions are
quantised to the point spacing), keeps the leader frozen at its current position over the whole
horizon, reads obstacles only from a CommonRoad Scenario's DynamicObstacles, plans no steering
angle or yaw rate, and its Euler loop never updates the speed inside a step (the IDM's desired gap
also multiplies by 2 sqrt(a b) where the model divides). So this is a small IDM of simgap's own.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from pydantic import Field

from simgap.planning.car_following import IdmParameters
from simgap.planning.collision import predict_traffic
from simgap.planning.protocol import Planner, PlannerSetup, World
from simgap.planning.reference_path import plan_reference_path
from simgap.planning.speed_profile import desired_speed, route_speeds
from simgap.scenario.road_frame import PathFrame
from simgap.trajectory import State, Trajectory, wrap_angle

__all__ = ["IdmPlanner", "IdmSettings"]

# the heading error the lateral quartic starts from is clipped to this [rad]
_MAX_HEADING_ERROR = math.radians(60.0)
# spacing of the reference path's points [m]
_PATH_SPACING_M = 0.2
# every this many points of the reference path are used to project positions onto it
_PROJECTION_STRIDE = 5
# integration sub-steps per dt
_SUBSTEPS = 5


class IdmSettings(IdmParameters):
    """Settings of the IDM lane follower: the IDM's parameters (`IdmParameters`, as the recorded
    traffic's IDM) and how it follows its lane."""

    horizon_s: float = Field(3.0, gt=0, le=20, description="length of every plan [s]")
    cruise_m_s: float = Field(10.0, gt=0, description="desired speed on a free, straight road [m/s]")
    max_lateral_acceleration: float = Field(
        3.0, gt=0, description="the desired speed is lowered where curvature would exceed this [m/s^2]")
    lookahead_s: float = Field(2.0, ge=0, description="the desired speed is the lowest of the speed profile "
                                                      "this far ahead [s]")
    convergence_s: float = Field(2.5, gt=0, description="an offset from the lane centre is closed over "
                                                        "this many seconds of travel [s]")
    convergence_min_m: float = Field(8.0, gt=0, description="... but over no less than this distance [m]")
    lane_margin_m: float = Field(0.3, ge=0, description="a participant is in the lane when its footprint comes "
                                                       "this close to the ego footprint's sides [m]")
    stop_at_route_end: bool = Field(True, description="stop at the end of the route (the goal lanelet's end)")


@dataclass
class IdmCycle:
    """What one call of `IdmPlanner.plan` did."""

    t: float = 0.0
    leader: int | None = None        # id of the participant followed at the first instant (-1: route end)
    gap_m: float = math.inf          # its gap at the first instant [m]
    desired_speed: float = 0.0
    seconds: float = 0.0


class IdmPlanner(Planner):
    """A lane-following Intelligent Driver Model for traffic not under test: keeps its route's
    centre line and the IDM gap to whatever is ahead in its lane, and stops at its route's end
    (see the module docstring)."""

    Settings = IdmSettings

    def __init__(self, setup: PlannerSetup, settings: IdmSettings | None = None):
        self.settings = s = settings or IdmSettings()
        self.vehicle = setup.vehicle
        self.dt = float(setup.dt)
        reach = s.horizon_s * self.vehicle.limits.max_speed + s.convergence_min_m
        # a fine spacing: plans interpolate positions linearly between its points, and a tracking
        # controller reads curvature from the plan's polyline
        self.reference_path = plan_reference_path(setup.lanelet_network, setup.planning_problem,
                                                  spacing=_PATH_SPACING_M, extension_back=reach,
                                                  extension_forward=reach)
        # projections need no fine spacing (1 m chords are within 2 cm of a 10 m radius)
        self._frame = PathFrame(self.reference_path.xy[::_PROJECTION_STRIDE])
        self.speed_profile, self.approach = route_speeds(self.reference_path, setup, s.cruise_m_s,
                                                         s.max_lateral_acceleration, s.comfortable_deceleration)
        self.stop_s = self.reference_path.route_s[1] if s.stop_at_route_end else math.inf
        self.last_cycle = IdmCycle()

    @property
    def failure_reason(self) -> str:    # type: ignore[override]  # read-only: derived from the last cycle
        return ""          # the IDM always has a plan

    def plan(self, observed: State, t: float, world: World) -> Trajectory | None:
        clock = time.perf_counter()
        self.last_cycle = cycle = IdmCycle(t=t)
        dt = float(world.dt)
        n = max(1, int(round(self.settings.horizon_s / dt)))
        times = t + dt * np.arange(n + 1)
        (s0,), (d0,) = self._frame.project(np.array([[observed.x, observed.y]]))
        s, v, a = self._longitudinal(float(s0), max(float(observed.v), 0.0), times, world, cycle)
        plan = self._trajectory(observed, float(d0), s, v, a, times, dt)
        cycle.seconds = time.perf_counter() - clock
        return plan

    # -- longitudinal: the IDM -----------------------------------------------------------------
    def _longitudinal(self, s0: float, v0: float, times: np.ndarray, world: World, cycle: IdmCycle):
        dt = float(times[1] - times[0])
        leaders = self._leaders(world, times)
        s, v = np.empty(len(times)), np.empty(len(times))
        a = np.zeros(len(times))
        s[0], v[0] = s0, v0
        h = dt / _SUBSTEPS
        for k in range(len(times)):
            gap, v_lead, who = self._nearest(leaders, k, s[k])
            desired = self._desired_speed(s[k], times[k], v[k])
            a[k] = self._acceleration(v[k], desired, gap, v_lead)
            if k == 0:
                cycle.leader, cycle.gap_m, cycle.desired_speed = who, gap, desired
            if k + 1 == len(times):
                break
            sk, vk = s[k], v[k]
            for j in range(_SUBSTEPS):
                gap_now = gap - (sk - s[k]) + v_lead * j * h
                acc = self._acceleration(vk, desired, gap_now, v_lead)
                v_next = max(vk + acc * h, 0.0)
                sk += 0.5 * (vk + v_next) * h
                vk = v_next
            s[k + 1], v[k + 1] = sk, vk
        return s, v, a

    def _desired_speed(self, s: float, t: float, v: float) -> float:
        lookahead = max(v, 1.0) * self.settings.lookahead_s
        return desired_speed(self.speed_profile, self.approach, s, t, v, lookahead).speed

    def _acceleration(self, v: float, desired: float, gap: float, v_lead: float) -> float:
        """The IDM: a [1 - (v / v0)^delta - (s* / s)^2], s* = s0 + max(0, v T + v dv / (2 sqrt(a b)))."""
        p = self.settings
        free = 1.0 - (v / max(desired, 0.1)) ** p.exponent if desired > 0.05 else -1.0
        interaction = p.interaction(v, v - v_lead, gap) if math.isfinite(gap) else 0.0
        acc = p.max_acceleration * (free - interaction)
        return float(np.clip(acc, -p.max_deceleration, min(p.max_acceleration, self.vehicle.limits.max_accel)))

    def _leaders(self, world: World, times: np.ndarray):
        """Per participant and instant: arc length of its centre on the path, its along-path speed,
        and whether it occupies the ego lane: arrays (participants, instants)."""
        if not world.traffic:
            return None
        pred = predict_traffic(world.traffic, times, lambda x, y: (x, y), 0.0, 0.0)
        m = len(times)
        pts = np.column_stack([pred.x.ravel(), pred.y.ravel()])
        s, d = self._frame.project(pts)
        s, d = s.reshape(-1, m), d.reshape(-1, m)
        theta = self.reference_path.polyline.interpolate(self.reference_path.theta, s)
        rel = pred.yaw - theta
        # half the participant's extent across the path, plus the ego's half width and the margin
        across = (np.abs(np.sin(rel)) * pred.half_length[:, None] + np.abs(np.cos(rel)) * pred.half_width[:, None])
        in_lane = np.abs(d) < across + 0.5 * self.vehicle.width + self.settings.lane_margin_m
        along = np.abs(np.cos(rel)) * pred.half_length[:, None] + np.abs(np.sin(rel)) * pred.half_width[:, None]
        v_pred = np.array([np.interp(times, tp.prediction.t, tp.prediction.v) for tp in world.traffic])
        ids = np.array([tp.id for tp in world.traffic])
        return s, along, in_lane, v_pred * np.cos(rel), ids

    def _nearest(self, leaders, k: int, s_ego: float) -> tuple[float, float, int | None]:
        """(gap, leader speed along the path, leader id) of the nearest thing ahead at instant k."""
        half = 0.5 * self.vehicle.length
        best = (self.stop_s - s_ego - half, 0.0, -1) if math.isfinite(self.stop_s) else (math.inf, 0.0, None)
        if leaders is not None:
            s, along, in_lane, v_along, ids = leaders
            ahead = in_lane[:, k] & (s[:, k] > s_ego)
            for j in np.flatnonzero(ahead):
                gap = float(s[j, k] - along[j, k] - s_ego - half)
                if gap < best[0]:
                    best = (gap, max(float(v_along[j, k]), 0.0), int(ids[j]))
        return best

    # -- lateral: back to the lane centre ---------------------------------------------------------
    def _trajectory(self, observed: State, d0: float, s: np.ndarray, v: np.ndarray, a: np.ndarray,
                    times: np.ndarray, dt: float) -> Trajectory:
        ref = self.reference_path
        theta0 = float(ref.polyline.interpolate(ref.theta, s[0]))
        # the direction the centre moves in: the body's yaw plus the sideslip of its steering angle
        course = observed.yaw + float(self._sideslip(math.tan(observed.steer) / self.vehicle.wheelbase))
        slope0 = math.tan(float(np.clip(wrap_angle(course - theta0), -_MAX_HEADING_ERROR, _MAX_HEADING_ERROR)))
        length = max(self.settings.convergence_min_m, max(float(observed.v), 0.0) * self.settings.convergence_s)
        d, dd, ddd = _quartic_to_zero(d0, slope0, s - s[0], length)
        x_ref, y_ref, theta, kappa = ref.interpolate(s)
        x = x_ref - d * np.sin(theta)
        y = y_ref + d * np.cos(theta)
        curvature = kappa + ddd          # small-offset approximation of the path's curvature
        # the centre's velocity points along the path; the body turns less by the kinematic sideslip
        # (the rear axle, which has none, runs inside the centre's path)
        yaw = theta + np.arctan(dd) - self._sideslip(curvature)
        yaw += 2.0 * math.pi * round((observed.yaw - yaw[0]) / (2.0 * math.pi))
        steer = np.clip(np.arctan(self.vehicle.wheelbase * curvature), -self.vehicle.limits.max_steer,
                        self.vehicle.limits.max_steer)
        x[0], y[0], yaw[0] = observed.x, observed.y, observed.yaw
        return Trajectory(dt, t=times, x=x, y=y, yaw=yaw, v=v, a=a, yaw_rate=v * curvature, steer=steer)

    def _sideslip(self, curvature):
        """Kinematic sideslip angle of the centre on a path of ``curvature`` (the rear axle has none)."""
        return np.arctan(self.vehicle.rear_axle_to_center * np.asarray(curvature, dtype=float))


def _quartic_to_zero(d0: float, slope0: float, u: np.ndarray, length: float):
    """d(u), d'(u), d''(u) of the quartic from (d0, slope0) at u = 0 to (0, 0, 0) at u = length (zero
    beyond). Its start curvature is free: replanned every cycle from the observed offset and
    heading, it closes the offset like a look-ahead steering law (a start curvature pinned to 0
    would be reset each cycle and never turn the vehicle)."""
    L = length
    # d = d0 + slope0 u + c2 u^2 + c3 u^3 + c4 u^4 with d(L) = d'(L) = d''(L) = 0
    A = np.array([[L**2, L**3, L**4], [2 * L, 3 * L**2, 4 * L**3], [2.0, 6 * L, 12 * L**2]])
    c2, c3, c4 = np.linalg.solve(A, np.array([-d0 - slope0 * L, -slope0, 0.0]))
    w = np.clip(u, 0.0, L)
    d = d0 + slope0 * w + c2 * w**2 + c3 * w**3 + c4 * w**4
    dd = slope0 + 2 * c2 * w + 3 * c3 * w**2 + 4 * c4 * w**3
    ddd = 2 * c2 + 6 * c3 * w + 12 * c4 * w**2
    inside = u < L
    return np.where(inside, d, 0.0), np.where(inside, dd, 0.0), np.where(inside, ddd, 0.0)
