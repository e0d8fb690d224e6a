"""What a planner returned, checked before the loop executes it.

A plan the loop can execute is a `Trajectory` of at least two states, every value finite, on the
scenario's time grid (its ``dt``, every ``t[k] = t[0] + k * dt``), starting at the planning time
(within half a step). Longer plans than `MAX_PLAN_HORIZON_S` are cut there: no controller needs
more, and every plan is kept in the run record.
"""

from __future__ import annotations

import numpy as np
from simgap_planner.messages import Trajectory as SdkTrajectory

from simgap.trajectory import STATE_FIELDS, Trajectory

MAX_PLAN_HORIZON_S = 30.0       # the horizon a plan is cut to [s]
GRID_TOLERANCE = 1e-6           # deviation from the time grid a plan may have, in steps


class InvalidPlan(ValueError):
    """A planner's return value that the loop cannot execute; the message says why."""


def executable_plan(plan: object, t: float, dt: float) -> Trajectory:
    """``plan``, returned by a planner at time ``t`` on a scenario of step ``dt``, cut to
    `MAX_PLAN_HORIZON_S`; raises `InvalidPlan` naming what is wrong."""
    if isinstance(plan, SdkTrajectory):     # the planner SDK's (a planner of simgap_planner, in simgap's process)
        plan = Trajectory(plan.dt, **{f: getattr(plan, f) for f in STATE_FIELDS})
    if not isinstance(plan, Trajectory):
        raise InvalidPlan(f"a {type(plan).__name__}, not a Trajectory (or None)")
    if len(plan) < 2:
        raise InvalidPlan(f"{len(plan)} state; a plan needs at least 2")
    if not abs(plan.dt - dt) <= GRID_TOLERANCE * dt:
        raise InvalidPlan(f"dt = {plan.dt:g} s, the scenario's time step is {dt:g} s")
    if not abs(plan.t[0] - t) <= dt / 2:
        raise InvalidPlan(f"it starts at t = {plan.t[0]:g} s, planned at t = {t:g} s (allowed: within {dt / 2:g} s)")
    states = min(len(plan), int(round(MAX_PLAN_HORIZON_S / dt)) + 1)
    columns = {f: getattr(plan, f)[:states] for f in STATE_FIELDS}
    for name, values in columns.items():
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise InvalidPlan(f"{name}[{bad[0]}] is {values[bad[0]]}; every value must be finite")
    off_grid = np.flatnonzero(np.abs(columns["t"] - (columns["t"][0] + dt * np.arange(states))) > GRID_TOLERANCE * dt)
    if off_grid.size:
        k = off_grid[0]
        raise InvalidPlan(f"t[{k}] = {columns['t'][k]:g} s is off the grid of {dt:g} s steps from t[0]")
    return plan if states == len(plan) else Trajectory(plan.dt, **columns)
