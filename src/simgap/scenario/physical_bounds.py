"""What a scenario file may state and still describe a road on which vehicles can drive: a
time step, planning problems and lanelets outside these bounds are refused when the file is read,
naming the file and the field, before anything runs."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from commonroad.common.util import Interval
from commonroad.planning.planning_problem import PlanningProblemSet
from commonroad.scenario.lanelet import LaneletNetwork

from simgap.errors import InputError
from simgap.vehicles.constants import MAX_SPEED

# recorded scenarios step 0.04-0.2 s; the controllers run at 50 Hz and up, so a step below their
# period, or above a few seconds, is no scenario simgap can run (and a tiny one only fills memory)
MIN_TIME_STEP_S, MAX_TIME_STEP_S = 0.01, 10.0
TIME_STEP_ALLOWED = f"{MIN_TIME_STEP_S:g} to {MAX_TIME_STEP_S:g} s, e.g. 0.1"
MIN_LANELET_WIDTH = 0.1     # m: a lanelet narrower than this everywhere carries no vehicle
MIN_LANE_WIDTH = 2.0        # m: the narrowest lane a generated road has (road design guides: 2.5 m and up)


def check_time_step(dt: float, *, file: str | Path | None, field: str) -> None:
    """Refuse a scenario time step outside [MIN_TIME_STEP_S, MAX_TIME_STEP_S] (nan and inf included)."""
    if not (math.isfinite(dt) and MIN_TIME_STEP_S <= dt <= MAX_TIME_STEP_S):
        raise InputError(f"time step {dt:g} s", file=file, field=field, allowed=TIME_STEP_ALLOWED)


def check_planning_problems(problems: PlanningProblemSet, file: str | Path) -> None:
    """Refuse a planning problem whose initial state no vehicle can be in (a position or
    orientation that is not a finite number, a speed below 0 or above `MAX_SPEED`) or whose
    goal window closes before its initial time."""
    for pid, problem in problems.planning_problem_dict.items():
        initial = problem.initial_state
        where = f"planningProblem {pid}.initialState"
        if isinstance(initial.position, np.ndarray) and not np.all(np.isfinite(initial.position)):
            raise InputError(f"position {initial.position.tolist()}", file=file, field=f"{where}.position",
                             allowed="finite coordinates in m")
        if not math.isfinite(float(initial.orientation)):
            raise InputError(f"orientation {initial.orientation}", file=file, field=f"{where}.orientation",
                             allowed="a finite angle in rad")
        if not 0.0 <= float(initial.velocity) <= MAX_SPEED:
            raise InputError(f"velocity {float(initial.velocity):g} m/s", file=file, field=f"{where}.velocity",
                             allowed=f"0 to {MAX_SPEED:g} m/s")
        windows = [state.time_step for state in problem.goal.state_list if hasattr(state, "time_step")]
        latest = max((int(w.end) if isinstance(w, Interval) else int(w) for w in windows), default=None)
        if latest is not None and int(initial.time_step) > latest:
            raise InputError(f"the initial time step {initial.time_step} lies after the goal window, which ends "
                             f"at step {latest}", file=file, field=f"{where}.time",
                             allowed=f"an initial time step <= {latest}")


def check_lanelets(network: LaneletNetwork, file: str | Path) -> None:
    """Refuse a lanelet with a coordinate that is not a finite number, or at most
    `MIN_LANELET_WIDTH` wide along its whole length (one that tapers to nothing at a merge is fine)."""
    for lanelet in network.lanelets:
        left, right = np.asarray(lanelet.left_vertices, float), np.asarray(lanelet.right_vertices, float)
        if not (np.all(np.isfinite(left)) and np.all(np.isfinite(right))):
            raise InputError("a bound with a coordinate that is not a finite number", file=file,
                             field=f"lanelet {lanelet.lanelet_id}", allowed="finite coordinates in m")
        widest = float(np.max(np.linalg.norm(left - right, axis=1)))
        if widest < MIN_LANELET_WIDTH:
            raise InputError(f"at most {widest:g} m wide along its whole length", file=file,
                             field=f"lanelet {lanelet.lanelet_id}",
                             allowed=f"a lanelet wider than {MIN_LANELET_WIDTH:g} m somewhere")
