"""The desired speed along the reference path.

A cruise speed (from the goal's velocity interval, or the configured default), lowered wherever
the reference path's curvature would push the lateral acceleration v^2 * kappa over the bound,
and lowered ahead of such places so that a comfortable deceleration reaches them in time.
"""

from __future__ import annotations

import numpy as np
from commonroad.planning.goal import GoalRegion

from simgap.planning.reference_path import ReferencePath

# the profile aims at this share of the lateral-acceleration bound, leaving room for plans
# whose curvature overshoots the reference path's while they converge onto it
_LATERAL_ACCELERATION_SHARE = 0.85


def cruise_speed(goal: GoalRegion | None, default: float, max_speed: float) -> float:
    """The default cruise speed, moved into the goal's velocity interval when it states one
    (10 % of the interval's width inside its bounds), and capped at ``max_speed``."""
    speed = default
    if goal is not None:
        for state in goal.state_list:
            interval = getattr(state, "velocity", None)
            if interval is None or not hasattr(interval, "start"):
                continue
            lo, hi = float(interval.start), float(interval.end)
            inset = 0.1 * max(hi - lo, 0.0)
            speed = float(np.clip(speed, lo + inset, hi - inset))
            break
    return float(min(max(speed, 0.0), max_speed))


class SpeedProfile:
    """Desired speed at every reference point (array ``v`` over ``reference.s``)."""

    def __init__(self, reference: ReferencePath, cruise: float, max_lateral_acceleration: float,
                 comfortable_deceleration: float):
        self.reference = reference
        self.cruise = cruise
        kappa = np.maximum(np.abs(reference.kappa), 1e-9)
        v = np.minimum(cruise, np.sqrt(_LATERAL_ACCELERATION_SHARE * max_lateral_acceleration / kappa))
        ds = np.diff(reference.s)
        for i in range(len(v) - 2, -1, -1):
            v[i] = min(v[i], np.sqrt(v[i + 1] ** 2 + 2.0 * comfortable_deceleration * ds[i]))
        self.v = v
        self.v.flags.writeable = False

    def desired_speed(self, s: float, distance: float) -> float:
        """The lowest desired speed between ``s`` and ``s + distance`` (reference arc length)."""
        ref_s = self.reference.s
        lo = int(np.searchsorted(ref_s, s, side="right")) - 1
        hi = int(np.searchsorted(ref_s, s + max(distance, 0.0), side="right"))
        lo, hi = max(lo, 0), min(max(hi, lo + 1), len(ref_s))
        here = float(np.interp(s, ref_s, self.v))
        return float(min(here, self.v[lo:hi].min()))
