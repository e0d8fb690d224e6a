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

from simgap.evaluate.frenet_frame import ReferencePath
from simgap.trajectory import Trajectory, wrap_angle


@dataclass(frozen=True)
class Aggregate:
    rms: float
    max: float
    mean: float
    p95: float

    @classmethod
    def of(cls, values: np.ndarray) -> "Aggregate":
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


def lateral_profile(traj: Trajectory, reference: ReferencePath) -> tuple[np.ndarray, np.ndarray]:
    """(s, d) of a trajectory's positions in the reference path's Frenet frame."""
    return reference.project(np.column_stack([traj.x, traj.y]))


def lateral_displacement_by_s(a: Trajectory, b: Trajectory, reference: ReferencePath,
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


def plan_in_force(plans: list[Trajectory], t: float, dt: float) -> Trajectory | None:
    """The latest plan made strictly before ``t`` (the one the vehicle was executing at ``t``)."""
    chosen = None
    for plan in plans:                      # plans are in the order they were made
        if plan.t[0] <= t - dt + 1e-9:
            chosen = plan
    return chosen


def tracking_errors(driven: Trajectory, plans: list[Trajectory]) -> TimeAlignedErrors:
    """Planned versus driven within one run (the assumption of perfect tracking): at every driven
    step, the state reached against the state the plan in force promised for that instant."""
    plans = sorted(plans, key=lambda p: p.t[0])
    rows = []
    for k in range(1, len(driven)):
        t = float(driven.t[k])
        plan = plan_in_force(plans, t, driven.dt)
        if plan is None or t > plan.t_end + 1e-9:
            continue
        promised = plan.at(t)
        rows.append((t, float(np.hypot(driven.x[k] - promised.x, driven.y[k] - promised.y)),
                     float(wrap_angle(driven.yaw[k] - promised.yaw)), float(driven.v[k] - promised.v)))
    if not rows:
        empty = np.array([])
        return TimeAlignedErrors(empty, empty, empty, empty)
    t, pos, yaw, v = (np.array(c) for c in zip(*rows))
    return TimeAlignedErrors(t, pos, yaw, v)
