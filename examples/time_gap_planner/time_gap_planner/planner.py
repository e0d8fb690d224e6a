"""A constant-time-gap lane-centre follower: a complete simgap planner in one file.

It uses nothing of simgap but its public planner API (`PlannerSetup`, `World`, `State`,
`Trajectory`) and the reference path of the route (`plan_reference_path`), so the file runs as is
by path (``--planner path/to/planner.py:TimeGapPlanner``) as well as installed (``--planner time_gap``).

Every cycle, from wherever the vehicle is (moving or not, off the lane centre, heading askew):

* longitudinal: the Intelligent Driver Model towards a desired speed (slowed for the path's
  curvature ahead), keeping ``min_gap_m + time_gap_s * v`` to the nearest road user ahead in
  its lane;
* lateral: a cubic from the observed offset and heading error back to the lane centre within
  ``return_time_s``.
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from simgap.planning import PlannerSetup, World
from simgap.planning.reference_path import plan_reference_path
from simgap.trajectory import State, Trajectory


class TimeGapSettings(BaseModel):
    """What the time-gap follower can be told."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    desired_speed_m_s: float = Field(8.0, gt=0, le=40, description="cruise speed on a straight road [m/s]")
    time_gap_s: float = Field(1.5, gt=0, le=5, description="time gap kept to the vehicle ahead [s]")
    min_gap_m: float = Field(2.0, ge=0, description="gap kept at standstill [m]")
    max_accel: float = Field(1.5, gt=0, description="IDM maximum acceleration [m/s^2]")
    comfortable_decel: float = Field(2.0, gt=0, description="IDM comfortable deceleration [m/s^2]")
    max_lateral_accel: float = Field(2.0, gt=0, description="bound on v^2 * curvature ahead [m/s^2]")
    return_time_s: float = Field(1.0, gt=0, description="time to return to the lane centre [s]")
    horizon_s: float = Field(3.0, gt=0, le=10, description="length of every plan [s]")
    lane_half_width_m: float = Field(1.75, gt=0, description="a road user this close to the centre line is in lane [m]")


class TimeGapPlanner:
    """Lane-centre follower with a constant time gap (IDM) to the road user ahead."""

    Settings = TimeGapSettings

    def __init__(self, setup: PlannerSetup, settings: TimeGapSettings | None):
        self.settings = settings or TimeGapSettings()
        self.vehicle = setup.vehicle
        self.path = plan_reference_path(setup.lanelet_network, setup.planning_problem,
                                        extension_forward=self.settings.horizon_s * 40.0 + 50.0)

    # -- the protocol ------------------------------------------------------------------------
    def plan(self, observed: State, t: float, world: World) -> Trajectory | None:
        cfg, dt = self.settings, world.dt
        s0, d0 = self._frenet(observed.x, observed.y)
        heading_error = _wrap(observed.yaw - float(self.path.interpolate(s0)[2]))
        n = int(round(cfg.horizon_s / dt)) + 1
        times = dt * np.arange(n)

        # longitudinal: IDM, stepped along the horizon
        leader = self._leader(s0, t, world)
        s, v = np.empty(n), np.empty(n)
        s[0], v[0] = s0, max(observed.v, 0.0)
        for k in range(1, n):
            a = self._idm(s[k - 1], v[k - 1], leader, times[k - 1])
            v[k] = max(v[k - 1] + a * dt, 0.0)
            s[k] = s[k - 1] + 0.5 * (v[k - 1] + v[k]) * dt

        # lateral: cubic from (d0, d0') to the centre line, reached after return_time_s
        T = cfg.return_time_s
        d_dot0 = v[0] * math.sin(heading_error)
        tau = np.minimum(times, T)
        c2 = (-3 * d0 - 2 * d_dot0 * T) / T ** 2
        c3 = (2 * d0 + d_dot0 * T) / T ** 3
        d = d0 + d_dot0 * tau + c2 * tau ** 2 + c3 * tau ** 3

        x_ref, y_ref, theta, kappa = self.path.interpolate(s)
        x, y = x_ref - d * np.sin(theta), y_ref + d * np.cos(theta)
        x[0], y[0] = observed.x, observed.y
        d_dot = np.gradient(d, dt)
        yaw = theta + np.arctan2(d_dot, np.maximum(v, 0.5))      # the path's heading, turned by the lateral motion
        yaw[0] = observed.yaw
        yaw = yaw[0] + np.concatenate([[0.0], np.cumsum([_wrap(a) for a in np.diff(yaw)])])
        yaw_rate = np.gradient(yaw, dt)
        steer = np.arctan(self.vehicle.wheelbase * kappa)         # feed-forward: the path's curvature
        accel = np.gradient(v, dt)
        return Trajectory(dt, t=t + times, x=x, y=y, yaw=yaw, v=v, a=accel, yaw_rate=yaw_rate, steer=steer)

    # -- parts ----------------------------------------------------------------------------------
    def _frenet(self, x: float, y: float) -> tuple[float, float]:
        """Arc length along the path and signed lateral offset (left positive) of (x, y)."""
        xy = self.path.xy
        k = int(np.hypot(xy[:, 0] - x, xy[:, 1] - y).argmin())
        theta = self.path.theta[k]
        dx, dy = x - xy[k, 0], y - xy[k, 1]
        along = dx * math.cos(theta) + dy * math.sin(theta)
        return float(self.path.s[k] + along), float(-dx * math.sin(theta) + dy * math.cos(theta))

    def _leader(self, s0: float, t: float, world: World):
        """The nearest road user ahead in lane: (its prediction, half the two lengths)."""
        best, best_gap = None, math.inf
        for other in world.traffic:
            here = other.prediction.at(t) if other.prediction.t[0] <= t <= other.prediction.t_end else \
                other.prediction[0] if t < other.prediction.t[0] else other.prediction[len(other.prediction) - 1]
            s, d = self._frenet(here.x, here.y)
            if abs(d) <= self.settings.lane_half_width_m and 0.0 < s - s0 < best_gap:
                best, best_gap = other, s - s0
        return None if best is None else (best, 0.5 * (best.length + self.vehicle.length))

    def _idm(self, s: float, v: float, leader, t: float) -> float:
        cfg = self.settings
        v_des = self._desired_speed(s)
        a = cfg.max_accel * (1.0 - (v / v_des) ** 4)
        if leader is not None:
            other, half_lengths = leader
            pred = other.prediction
            there = pred.at(min(max(t, pred.t[0]), pred.t_end))
            s_other, _ = self._frenet(there.x, there.y)
            gap = max(s_other - s - half_lengths, 0.1)
            wanted = cfg.min_gap_m + v * cfg.time_gap_s + v * (v - there.v) / (
                2.0 * math.sqrt(cfg.max_accel * cfg.comfortable_decel))
            a -= cfg.max_accel * (max(wanted, 0.0) / gap) ** 2
        return max(a, -8.0)

    def _desired_speed(self, s: float) -> float:
        """The desired speed, lowered to keep v^2 * curvature within bound over the next 30 m."""
        cfg = self.settings
        kappa = np.abs(self.path.interpolate(np.linspace(s, s + 30.0, 16))[3]).max()
        return min(cfg.desired_speed_m_s, math.sqrt(cfg.max_lateral_accel / kappa)) if kappa > 1e-6 \
            else cfg.desired_speed_m_s


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi

