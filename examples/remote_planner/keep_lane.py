"""A planner in a process of its own: keep the lane at a constant speed, served with simgap_planner.

It needs only the client library (numpy, protobuf, pyzmq; any Python >= 3.9), not simgap:

    pip install -e planner-protocol/python          # into the planner's own environment
    simgap run SCENARIO.xml --out runs/x --planner 'exec:python examples/remote_planner/keep_lane.py'

Each cycle it projects the observed position onto the route (the lane's centre line to the goal,
`Setup.route`) and marches along it for three seconds at the cruise speed.
"""

import numpy as np

from simgap_planner import Trajectory, serve


class KeepLane:
    def __init__(self, setup):
        self.dt = setup.dt
        self.speed = float(setup.settings.get("speed_m_s", 8.0))
        self.route = setup.route
        steps = np.hypot(*np.diff(self.route, axis=0).T)
        self.s = np.concatenate([[0.0], np.cumsum(steps)])

    def plan(self, observed, t, world):
        k = np.arange(int(round(3.0 / self.dt)) + 1)
        accel = np.clip((self.speed - observed.v) / 3.0, -2.0, 2.0)      # reach the cruise speed gently
        v = np.maximum(observed.v + accel * k * self.dt, 0.0)
        s = self.arc_length_at(observed.x, observed.y) + np.concatenate([[0.0], np.cumsum(v[:-1] * self.dt)])
        x, y = np.interp(s, self.s, self.route[:, 0]), np.interp(s, self.s, self.route[:, 1])
        yaw = np.unwrap(np.arctan2(np.gradient(y), np.gradient(x)))
        x[0], y[0], yaw[0] = observed.x, observed.y, observed.yaw       # the plan starts where the car is
        return Trajectory(self.dt, t=t + k * self.dt, x=x, y=y, yaw=yaw, v=v, a=np.full(len(k), accel))

    def arc_length_at(self, x, y):
        """The route's arc length at the point nearest to (x, y)."""
        start, step = self.route[:-1], np.diff(self.route, axis=0)
        along = np.clip(np.einsum("ij,ij->i", [x, y] - start, step) / np.einsum("ij,ij->i", step, step), 0.0, 1.0)
        nearest = int(np.argmin(np.hypot(*(start + along[:, None] * step - [x, y]).T)))
        return self.s[nearest] + along[nearest] * (self.s[nearest + 1] - self.s[nearest])


if __name__ == "__main__":
    serve(KeepLane)
