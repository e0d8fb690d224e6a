"""Error metrics between trajectories.

Within one run (planned versus driven) and across fidelities (driven versus driven):

- matched by time: position error (Euclidean distance), orientation error (wrapped to
  (-pi, pi], unlike the CommonRoad–Autoware bridge), velocity error — as the bridge defines them;
- matched by arc length: lateral displacement d(s) in the Frenet frame of a reference path, so
  that a speed difference does not show up as a position error.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simgap.scenario.road_frame import PathFrame
from simgap.trajectory import Trajectory, wrap_angle


@dataclass(frozen=True)
class Aggregate:
    rms: float
    max: float
    mean: float
    p95: float

    @classmethod
    def of(cls, values: np.ndarray) -> Aggregate:
        v = np.abs(np.asarray(values, dtype=float))
        v = v[np.isfinite(v)]
        if len(v) == 0:
            return cls(float("nan"), float("nan"), float("nan"), float("nan"))
        return cls(float(np.sqrt(np.mean(v**2))), float(v.max()), float(v.mean()),
                   float(np.percentile(v, 95)))

    def as_dict(self) -> dict[str, float]:
        return {"rms": self.rms, "max": self.max, "mean": self.mean, "p95": self.p95}


@dataclass(frozen=True)
class TimeAlignedErrors:
    t: np.ndarray
    position: np.ndarray
    orientation: np.ndarray
    velocity: np.ndarray


def time_aligned_errors(a: Trajectory, b: Trajectory) -> TimeAlignedErrors:
    """Errors of ``b`` relative to ``a`` at the times both cover (b sampled at a's times)."""
    t0, t1 = max(a.t[0], b.t[0]), min(a.t_end, b.t_end)
    mask = (a.t >= t0 - 1e-9) & (a.t <= t1 + 1e-9)
    ts = a.t[mask]
    if len(ts) == 0:
        empty = np.array([])
        return TimeAlignedErrors(empty, empty, empty, empty)
    bx = np.interp(ts, b.t, b.x)
    by = np.interp(ts, b.t, b.y)
    bv = np.interp(ts, b.t, b.v)
    byaw = np.interp(ts, b.t, np.unwrap(b.yaw))
    return TimeAlignedErrors(
        t=ts,
        position=np.hypot(bx - a.x[mask], by - a.y[mask]),
        orientation=wrap_angle(byaw - a.yaw[mask]),
        velocity=bv - a.v[mask],
    )


def lateral_profile(traj: Trajectory, reference: PathFrame) -> tuple[np.ndarray, np.ndarray]:
    """(s, d) of a trajectory's positions in the reference path's Frenet frame."""
    return reference.project(np.column_stack([traj.x, traj.y]))


def lateral_displacement_by_s(a: Trajectory, b: Trajectory, reference: PathFrame,
                              ds: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """d_b(s) - d_a(s) on a common s grid covering the stretch both trajectories drove."""
    sa, da = lateral_profile(a, reference)
    sb, db = lateral_profile(b, reference)
    lo, hi = max(sa.min(), sb.min()), min(sa.max(), sb.max())
    if hi <= lo:
        return np.array([]), np.array([])
    grid = np.arange(lo, hi + 1e-9, ds)
    return grid, interp_by_s(grid, sb, db) - interp_by_s(grid, sa, da)


def interp_by_s(grid: np.ndarray, s: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Interpolate d(s) where s may stall (standstill): keep the first sample of each s."""
    order = np.argsort(s, kind="stable")
    s_sorted, d_sorted = s[order], d[order]
    keep = np.concatenate([[True], np.diff(s_sorted) > 1e-6])
    return np.interp(grid, s_sorted[keep], d_sorted[keep])


@dataclass(frozen=True)
class PromisedStates:
    """For each driven step after the first: the state the plan in force promised for it."""

    index: np.ndarray          # driven step indices
    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    v: np.ndarray


def promised_states(driven: Trajectory, plans: list[Trajectory]) -> PromisedStates:
    plans = sorted(plans, key=lambda p: p.t[0])
    starts = np.array([p.t[0] for p in plans])
    rows = []
    for k in range(1, len(driven)):
        t = float(driven.t[k])
        # the plan in force: the latest one made at or before t - dt (the vehicle executed it at t)
        i = int(np.searchsorted(starts, t - driven.dt + 1e-9, side="right")) - 1
        if i < 0 or t > plans[i].t_end + 1e-9:
            continue
        st = plans[i].at(t)
        rows.append((k, st.x, st.y, st.yaw, st.v))
    if not rows:                  # no plan in force at any step (a planner that never planned)
        return PromisedStates(np.array([], dtype=int), *(np.array([]) for _ in range(4)))
    k, x, y, yaw, v = (np.array(c) for c in zip(*rows))
    return PromisedStates(k.astype(int), x, y, yaw, v)


def tracking_errors(driven: Trajectory, plans: list[Trajectory]) -> TimeAlignedErrors:
    """Planned versus driven within one run (the assumption of perfect tracking): at every driven
    step, the state reached against the state the plan in force promised for that instant."""
    p = promised_states(driven, plans)
    k = p.index
    return TimeAlignedErrors(driven.t[k], np.hypot(driven.x[k] - p.x, driven.y[k] - p.y),
                             wrap_angle(driven.yaw[k] - p.yaw), driven.v[k] - p.v)


@dataclass(frozen=True)
class FrenetTrackingErrors:
    t: np.ndarray
    s: np.ndarray              # driven arc length along the reference path [m]
    lateral: np.ndarray        # d_driven - d_promised [m] (> 0: left of the promise)
    longitudinal: np.ndarray   # s_driven - s_promised [m] (> 0: ahead of the promise)


def frenet_tracking_errors(driven: Trajectory, plans: list[Trajectory],
                           reference: PathFrame) -> FrenetTrackingErrors:
    """Planned versus driven, split into the reference path's lateral and longitudinal
    directions."""
    p = promised_states(driven, plans)
    k = p.index
    if len(k) == 0:
        empty = np.array([])
        return FrenetTrackingErrors(empty, empty, empty, empty)
    s_d, d_d = reference.project(np.column_stack([driven.x[k], driven.y[k]]))
    s_p, d_p = reference.project(np.column_stack([p.x, p.y]))
    return FrenetTrackingErrors(driven.t[k], s_d, d_d - d_p, s_d - s_p)


@dataclass(frozen=True)
class Comfort:
    peak_lateral_acceleration: float      # max |v * yaw rate| [m/s^2]
    peak_longitudinal_acceleration: float  # max |a| [m/s^2]
    peak_jerk: float                      # max |da/dt| [m/s^3]

    def as_dict(self) -> dict[str, float]:
        return {"peak_lateral_acceleration": self.peak_lateral_acceleration,
                "peak_longitudinal_acceleration": self.peak_longitudinal_acceleration,
                "peak_jerk": self.peak_jerk}


def comfort(driven: Trajectory) -> Comfort:
    """Peak accelerations and jerk of a driven trajectory."""
    if len(driven) < 2:
        return Comfort(0.0, 0.0, 0.0)
    lateral = np.abs(driven.v * driven.yaw_rate)
    jerk = np.abs(np.diff(driven.a)) / driven.dt
    return Comfort(float(lateral.max()), float(np.abs(driven.a).max()), float(jerk.max()))
