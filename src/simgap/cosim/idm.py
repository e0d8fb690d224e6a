"""Recorded traffic that reacts: each recorded vehicle drives along its recorded path, its speed
set by an Intelligent Driver Model towards whatever is ahead on that path (agents included).

Undisturbed, a vehicle keeps to its recording exactly: it tracks the recording's position along
the path (``s_rec(t)``) and snaps onto it when it is there. With something ahead on its path (a
footprint within half the two widths of the path, ahead of its front), the IDM's interaction
term brakes it; once free, it catches up with the recording at ``CATCH_UP_S`` per metre behind.
Pedestrians, cyclists and static obstacles replay their recording.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from commonroad.scenario.scenario import Scenario
from pydantic import Field

from simgap.cosim.obstacle_reach import ObstacleReach
from simgap.planning.car_following import IdmParameters
from simgap.planning.protocol import TrafficParticipant
from simgap.polyline import arc_length
from simgap.scenario.obstacles import RecordedObstacle, recorded_obstacles
from simgap.trajectory import State, Trajectory


class TrafficIdm(IdmParameters):
    """The IDM's parameters (`IdmParameters`, as the `idm` planner's) and how a recorded vehicle
    keeps to its recording and is seen by planners."""

    catch_up_s: float = Field(2.0, gt=0, description="1 / gain of the tracking of the recorded position [s]")
    tracking_s: float = Field(0.5, gt=0, description="time constant of the speed tracking [s]")
    lookahead_m: float = Field(80.0, gt=0, description="how far ahead on its path a vehicle looks [m]")
    prediction_s: float = Field(4.0, gt=0, description="how far planners see it ahead (constant speed on its "
                                                       "path) [s]")


@dataclass
class _PathVehicle:
    """One recorded vehicle on its recorded path: arc length ``s`` and speed ``v``."""

    obstacle: RecordedObstacle
    xy: np.ndarray           # recorded path points (n, 2)
    path_s: np.ndarray       # arc length at the points
    yaw: np.ndarray          # heading at the points (unwrapped)
    rec_s: np.ndarray        # recorded arc length at the recording's time steps
    s: float = 0.0
    v: float = 0.0
    present: bool = False
    done: bool = False
    prediction: Trajectory | None = field(default=None, repr=False)

    def pose(self, s: float) -> tuple[float, float, float]:
        return (float(np.interp(s, self.path_s, self.xy[:, 0])), float(np.interp(s, self.path_s, self.xy[:, 1])),
                float(np.interp(s, self.path_s, self.yaw)))

    def recorded(self, t: float) -> tuple[float, float]:
        m = self.obstacle.motion
        return float(np.interp(t, m.t, self.rec_s)), float(np.interp(t, m.t, m.v))


def _path_vehicle(obstacle: RecordedObstacle) -> _PathVehicle | None:
    m = obstacle.motion
    xy = np.stack([m.x, m.y], axis=1)
    rec_s = arc_length(xy)
    steps = np.diff(rec_s)                 # (a segment's length to within 1e-14 m of its hypot)
    if rec_s[-1] < 1.0:
        return None                    # it hardly moves: replay it
    keep = np.concatenate([[True], steps > 1e-3])
    xy, path_s = xy[keep], rec_s[keep]
    yaw = np.unwrap(np.asarray(m.yaw)[keep])
    # continue the path straight for a while, so that a late vehicle can finish its way
    d = np.array([math.cos(yaw[-1]), math.sin(yaw[-1])])
    tail = 50.0
    xy = np.vstack([xy, xy[-1] + tail * d])
    path_s, yaw = np.append(path_s, path_s[-1] + tail), np.append(yaw, yaw[-1])
    return _PathVehicle(obstacle, xy, path_s, yaw, rec_s)


class IdmTraffic:
    """Recorded vehicles driven by an IDM along their recorded paths (see the module docstring);
    a `simgap.cosim.traffic.Traffic`."""

    def __init__(self, scenario: Scenario, parameters: TrafficIdm | None = None,
                 obstacles: Sequence[RecordedObstacle] | None = None):
        self.p = parameters or TrafficIdm()
        self.dt = float(scenario.dt)
        self._replayed: list[RecordedObstacle] = []
        self._driven: list[_PathVehicle] = []
        for obstacle in recorded_obstacles(scenario) if obstacles is None else obstacles:
            vehicle = _path_vehicle(obstacle) if obstacle.vehicle and not obstacle.static else None
            if vehicle is None:
                self._replayed.append(obstacle)
            else:
                self._driven.append(vehicle)
        self.reach = ObstacleReach.of([TrafficParticipant(o.id, o.length, o.width, o.motion) for o in self._replayed],
                                      [pv.obstacle.id for pv in self._driven])
        self.driven_ids = tuple(pv.obstacle.id for pv in self._driven)
        self._place(0.0)

    # -- what the loop and planners see -------------------------------------------------------
    def participants(self) -> Sequence[TrafficParticipant]:
        out = [TrafficParticipant(o.id, o.length, o.width, o.motion) for o in self._replayed]
        out += [TrafficParticipant(pv.obstacle.id, pv.obstacle.length, pv.obstacle.width, pv.prediction)
                for pv in self._driven if pv.present and pv.prediction is not None]
        return out

    def poses(self, t: float, ids: Collection[int] | None = None) -> dict[int, tuple[State, float, float]]:
        wanted = None if ids is None else set(ids)
        out = {o.id: (o.motion.at(t), o.length, o.width) for o in self._replayed
               if (wanted is None or o.id in wanted) and o.motion.t[0] - 1e-9 <= t <= o.motion.t_end + 1e-9}
        for pv in self._driven:
            if pv.present and (wanted is None or pv.obstacle.id in wanted):
                x, y, yaw = pv.pose(pv.s)
                out[pv.obstacle.id] = (State(t, x, y, yaw, pv.v), pv.obstacle.length, pv.obstacle.width)
        return out

    # -- motion -------------------------------------------------------------------------------
    def _place(self, t: float) -> None:
        """Vehicles whose recording starts now enter at their recorded place and speed."""
        for pv in self._driven:
            m = pv.obstacle.motion
            if not pv.present and not pv.done and m.t[0] - 1e-9 <= t <= m.t_end + 1e-9:
                pv.s, pv.v = pv.recorded(t)
                pv.present = True
            if pv.present:
                pv.prediction = self._predict(pv, t)

    def advance(self, t: float, dt: float, agents: Mapping[int, TrafficParticipant]) -> None:
        others = self._obstacles_at(t, agents)
        for pv in self._driven:
            if not pv.present:
                continue
            a = self._acceleration(pv, t, others)
            v_next = max(0.0, pv.v + a * dt)
            s_next = pv.s + 0.5 * (pv.v + v_next) * dt
            s_rec, v_rec = pv.recorded(t + dt)
            if a >= self._tracking(pv, t) - 1e-9 and abs(s_next - s_rec) < 0.05:
                s_next, v_next = s_rec, v_rec          # undisturbed: exactly on the recording
            pv.s, pv.v = s_next, v_next
            if pv.s >= pv.path_s[-1] - 1e-6 or t + dt > pv.obstacle.motion.t_end + 10.0:
                pv.present, pv.done = False, True
        self._place(t + dt)

    def _tracking(self, pv: _PathVehicle, t: float) -> float:
        s_rec, v_rec = pv.recorded(t)
        v_aim = max(0.0, v_rec + (s_rec - pv.s) / self.p.catch_up_s)
        return float(np.clip((v_aim - pv.v) / self.p.tracking_s, -self.p.max_deceleration, self.p.max_acceleration))

    def _acceleration(self, pv: _PathVehicle, t: float, others: np.ndarray) -> float:
        a = self._tracking(pv, t)
        gap, v_lead = self._leader(pv, others)
        if gap is None:
            return a
        p = self.p
        interaction = p.max_acceleration * (1.0 - p.interaction(pv.v, pv.v - v_lead, gap))
        return float(max(min(a, interaction), -p.max_deceleration))

    def _obstacles_at(self, t: float, agents: Mapping[int, TrafficParticipant]) -> np.ndarray:
        """Rows (id, x, y, yaw, v, length, width) of everything that can be ahead of a vehicle."""
        poses = {aid: (tp.prediction.at(t), tp.length, tp.width) for aid, tp in agents.items()} | self.poses(t)
        rows = [(oid, st.x, st.y, st.yaw, st.v, length, width) for oid, (st, length, width) in poses.items()]
        return np.array(rows, dtype=float).reshape(-1, 7)

    def _leader(self, pv: _PathVehicle, others: np.ndarray) -> tuple[float | None, float]:
        """Gap to and along-path speed of the nearest thing on ``pv``'s path ahead."""
        if not len(others):
            return None, 0.0
        ahead = (pv.path_s > pv.s) & (pv.path_s < pv.s + self.p.lookahead_m)
        if not ahead.any():
            return None, 0.0
        pts, ss, yaws = pv.xy[ahead], pv.path_s[ahead], pv.yaw[ahead]
        mask = others[:, 0] != pv.obstacle.id
        o = others[mask]
        if not len(o):
            return None, 0.0
        dist = np.hypot(o[:, None, 1] - pts[None, :, 0], o[:, None, 2] - pts[None, :, 1])
        k = dist.argmin(axis=1)
        lateral = dist[np.arange(len(o)), k]
        on_path = lateral < 0.5 * (o[:, 6] + pv.obstacle.width) + 0.3
        if not on_path.any():
            return None, 0.0
        gaps = ss[k] - pv.s - 0.5 * (o[:, 5] + pv.obstacle.length)
        gaps = np.where(on_path, gaps, np.inf)
        j = int(gaps.argmin())
        v_lead = o[j, 4] * math.cos(o[j, 3] - yaws[k[j]])
        return float(gaps[j]), float(v_lead)

    def _predict(self, pv: _PathVehicle, t: float) -> Trajectory:
        n = int(round(self.p.prediction_s / self.dt)) + 1
        s = pv.s + pv.v * self.dt * np.arange(n)
        x, y, yaw = (np.interp(s, pv.path_s, col) for col in (pv.xy[:, 0], pv.xy[:, 1], pv.yaw))
        return Trajectory(self.dt, t=t + self.dt * np.arange(n), x=x, y=y, yaw=yaw, v=np.full(n, pv.v),
                          a=np.zeros(n), yaw_rate=np.zeros(n), steer=np.zeros(n))
