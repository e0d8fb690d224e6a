"""A planner written against the planner SDK: keep the lane, at a cruise speed or behind traffic.

The same file runs in simgap's process and in a process of its own, with the same result (the
same fingerprint):

    simgap run SCENARIO.xml --out runs/in --planner examples/remote_planner/keep_lane.py:KeepLane
    simgap run SCENARIO.xml --out runs/own --planner 'exec:python examples/remote_planner/keep_lane.py'

In its own process it needs only the client library (numpy, protobuf, pyzmq; any Python >= 3.9),
not simgap: ``pip install -e planner-protocol/python`` into the planner's own environment.

Each cycle it projects the observed position onto the route (the lane's centre line to the goal,
``setup.route``) and marches along it for three seconds, towards the cruise speed (the setting
``speed_m_s``, at most the vehicle's top speed) within the vehicle's acceleration limit, or
slower when a road user ahead on the route is closer than two seconds at that speed.
"""

import numpy as np
from simgap_planner import Trajectory, serve

HORIZON_S = 3.0
TIME_GAP_S = 2.0
IN_LANE_M = 2.0         # a road user this close to the route is in the lane


class KeepLane:
    def __init__(self, setup):
        self.dt = setup.dt
        limits = setup.vehicle.limits
        self.speed = min(float(setup.settings.get("speed_m_s", 8.0)), limits.max_speed)
        self.max_accel = min(2.0, limits.max_accel)
        self.length = setup.vehicle.length
        self.route = setup.route
        steps = np.hypot(*np.diff(self.route, axis=0).T)
        self.s = np.concatenate([[0.0], np.cumsum(steps)])

    def plan(self, observed, t, world):
        k = np.arange(int(round(HORIZON_S / self.dt)) + 1)
        here, _ = self.on_route(observed.x, observed.y)
        speed = min([self.speed] + [self.speed_behind(here, p) for p in world.traffic])
        accel = np.clip((speed - observed.v) / HORIZON_S, -self.max_accel, self.max_accel)
        v = np.maximum(observed.v + accel * k * self.dt, 0.0)
        s = here + np.concatenate([[0.0], np.cumsum(v[:-1] * self.dt)])
        x, y = np.interp(s, self.s, self.route[:, 0]), np.interp(s, self.s, self.route[:, 1])
        yaw = np.unwrap(np.arctan2(np.gradient(y), np.gradient(x)))
        x[0], y[0], yaw[0] = observed.x, observed.y, observed.yaw       # the plan starts where the car is
        return Trajectory(self.dt, t=t + k * self.dt, x=x, y=y, yaw=yaw, v=v, a=np.full(len(k), accel))

    def speed_behind(self, here, participant):
        """The speed that keeps the time gap to ``participant`` when it is ahead in the lane."""
        along, off = self.on_route(participant.prediction.x[0], participant.prediction.y[0])
        gap = along - here - (self.length + participant.length) / 2
        if off > IN_LANE_M or along <= here:
            return self.speed
        return max(gap, 0.0) / TIME_GAP_S

    def on_route(self, x, y):
        """The route's arc length at the point nearest to (x, y), and the distance to it."""
        start, step = self.route[:-1], np.diff(self.route, axis=0)
        along = np.clip(np.einsum("ij,ij->i", [x, y] - start, step) / np.einsum("ij,ij->i", step, step), 0.0, 1.0)
        distances = np.hypot(*(start + along[:, None] * step - [x, y]).T)
        nearest = int(np.argmin(distances))
        return self.s[nearest] + along[nearest] * (self.s[nearest + 1] - self.s[nearest]), float(distances[nearest])


if __name__ == "__main__":
    serve(KeepLane)
