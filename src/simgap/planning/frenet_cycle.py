"""The typed values of one cycle of the Frenet planner (`simgap.planning.frenet`): where it starts
(`Start`), what it leaves the next (`CycleMemory`, `Manoeuvre`), and what it did (`PlanningCycle`,
timed by phase: `PHASES`, `lap`)."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from simgap.planning.plan_choice import ChoiceKind
from simgap.planning.protocol import PlanOutcome
from simgap.trajectory import Trajectory

PHASES = ("projection", "sampling", "evaluation", "collision", "conversion")


@dataclass(frozen=True)
class Start:
    """Where a planning cycle starts: the observed state in the Frenet frame (core layout:
    ``x0_lon`` = s, s_dot, s_ddot; ``x0_lat`` = d, d_dot, d_ddot), the rear axle in the local
    frame, and the speed the cycle aims at."""

    t: float
    dt: float
    x0_lon: np.ndarray
    x0_lat: np.ndarray
    x_rear: float
    y_rear: float
    yaw_local: float
    v: float
    desired: float
    low_velocity: bool
    may_overtake: bool = True     # not when the goal is near: it is entered behind slower traffic
    lateral_bound: float = math.inf   # plans within this lateral acceleration are preferred [m/s^2]
    goal_in_reach: bool = False   # a plan may reach the goal within the horizon: one that does is preferred


@dataclass(frozen=True)
class Manoeuvre:
    """A chosen sample's end conditions: absolute end time [s], end speed [m/s], lateral end offset [m]."""

    t_end: float
    v_end: float
    d_end: float


@dataclass(frozen=True)
class CycleMemory:
    """What a cycle leaves the next: the manoeuvre it chose (None: none, or none to continue),
    when it ran (None: never), and its plan (None: none, or the vehicle left it)."""

    manoeuvre: Manoeuvre | None = None
    t: float | None = None
    last_plan: Trajectory | None = None


@dataclass
class PlanningCycle:
    """What one call of `FrenetPlanner.plan` did (for diagnostics and benchmarks)."""

    t: float = 0.0
    samples: int = 0
    evaluated: int = 0         # samples the core evaluated (in its cost order, as they were looked at)
    feasible: int = 0          # feasible among them
    floor_misses: int = 0      # samples whose cost came out below cost_order's floor (none, or a bug)
    checked: int = 0
    rejected_infeasible: int = 0
    rejected_road: int = 0
    rejected_traffic: int = 0
    rejected_lateral_acceleration: int = 0
    low_velocity: bool = False
    relaxed: bool = False
    desired_speed: float = 0.0
    outcome: PlanOutcome | None = None     # None until the cycle ends
    choice: ChoiceKind | None = None       # why the plan won (None: no plan, or a second look's)
    timings: dict[str, float] = field(default_factory=lambda: {p: 0.0 for p in PHASES})


def lap(cycle: PlanningCycle, phase: str, since: float) -> float:
    """Add the time since ``since`` to ``cycle``'s ``phase``; returns now."""
    now = time.perf_counter()
    cycle.timings[phase] += now - since
    return now
