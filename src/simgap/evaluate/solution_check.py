"""Whether each agent's solution is valid, by commonroad-drivability-checker's solution checker, and
the first reason when it is not.

The checks are the library's own (`commonroad_dc.feasibility.solution_checker`), in the order its
``valid_solution`` runs them, on each agent's part of the solution alone: the goal reached, the
start at the planning problem's initial state, no collision with the scenario's obstacles, inside
the road boundary, no collision with another agent, and feasible for the vehicle model (its
inputs reconstructed state by state). The first that fails is the reason; the checks after it are
not run. Where the library only says *that* something failed, the time (and the obstacle) is
located with its own collision objects.

The feasibility check is slow (milliseconds per state, most of a run's evaluation), so it runs
after the run is saved (`simgap.experiment.single_run`), and its verdicts are cached by the hash of
what it checks (`SolutionCheckCache`): a run that drives the same trajectory again — a rerun, a
repeated ideal run — is not checked twice.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import json
import os
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from commonroad.common.solution import PlanningProblemSolution, Solution
from commonroad.planning.planning_problem import PlanningProblemSet
from commonroad.scenario.scenario import Scenario

from simgap.files import atomic_write_text


@dataclass(frozen=True)
class SolutionCheck:
    """One agent's verdict: valid (None: could not be checked) and why not."""

    valid: bool | None
    reason: str = ""


def check_solution(solution: Solution, scenario: Scenario, problems: PlanningProblemSet) -> dict[int, SolutionCheck]:
    """The verdict on each agent's part of ``solution``."""
    out = {}
    for pps in solution.planning_problem_solutions:
        try:
            out[pps.planning_problem_id] = _check_agent(pps, solution, scenario, problems)
        except Exception as exc:     # the library failed on this input: no verdict, the run goes on
            out[pps.planning_problem_id] = SolutionCheck(None, f"the check raised {type(exc).__name__}: "
                                                               f"{_first_line(exc)}")
    return out


def _check_agent(pps: PlanningProblemSolution, solution: Solution, scenario: Scenario,
                 problems: PlanningProblemSet) -> SolutionCheck:
    from commonroad_dc.feasibility import solution_checker as checker

    pid = pps.planning_problem_id
    alone = Solution(solution.scenario_id, [pps], date=None)
    problem_set = PlanningProblemSet([problems.planning_problem_dict[pid]])
    try:
        checker.goal_reached(scenario, problem_set, alone)
    except checker.GoalNotReachedException:
        end = pps.trajectory.state_list[-1].time_step * scenario.dt
        return SolutionCheck(False, f"goal not reached (the trajectory ends at t = {end:.1f} s)")
    try:
        checker.starts_at_correct_state(alone, problem_set)
    except checker.SolutionCheckerException as exc:
        return SolutionCheck(False, "does not start at the planning problem's initial state: " + _first_line(exc))
    try:
        checker.obstacle_collision(scenario, problem_set, alone)
    except checker.CollisionException:
        return SolutionCheck(False, _obstacle_collision(pps, scenario))
    try:
        checker.boundary_collision(scenario, problem_set, alone)
    except checker.CollisionException:
        return SolutionCheck(False, _boundary_collision(pps, scenario))
    others = [o for o in solution.planning_problem_solutions if o.planning_problem_id != pid]
    for other in others:
        pair = Solution(solution.scenario_id, [pps, other], date=None)
        pair_problems = PlanningProblemSet([problems.planning_problem_dict[pid],
                                            problems.planning_problem_dict[other.planning_problem_id]])
        try:
            checker.ego_collision(scenario, pair_problems, pair)
        except checker.CollisionException:
            return SolutionCheck(False, _agent_collision(pps, other, scenario.dt))
    try:
        feasible, inputs, _ = checker.solution_feasible(alone, scenario.dt, problem_set)[pid]
    except checker.SolutionCheckerException as exc:
        return SolutionCheck(False, f"infeasible for {_model(pps)}: " + _first_line(exc.__cause__ or exc))
    if not feasible:
        k = inputs.state_list[-1].time_step
        return SolutionCheck(False, f"infeasible for {_model(pps)} at t = {(k + 1) * scenario.dt:.1f} s (no input "
                                    f"reaches that state from the one at t = {k * scenario.dt:.1f} s)")
    return SolutionCheck(True)


def _model(pps: PlanningProblemSolution) -> str:
    return f"{pps.vehicle_model.name}{pps.vehicle_type.value}"


def _first_line(exc: BaseException) -> str:
    return (str(exc).strip().splitlines() or [type(exc).__name__])[0]


# ----------------------------------------------------------------------- locating a collision
def _ego_object(pps: PlanningProblemSolution):
    """The agent's occupancy over time, as the checker builds it (the vehicle type's box)."""
    from commonroad.prediction.prediction import TrajectoryPrediction
    from commonroad_dc.collision.collision_detection.pycrcc_collision_dispatch import create_collision_object
    from commonroad_dc.feasibility.vehicle_dynamics import VehicleDynamics

    shape = VehicleDynamics.from_model(pps.vehicle_model, pps.vehicle_type).shape
    return create_collision_object(TrajectoryPrediction(pps.trajectory, shape))


def _first_contact(ego, other) -> int | None:
    """The first time step at which the time-variant ``ego`` touches ``other`` (None: never)."""
    for k in range(ego.time_start_idx(), ego.time_end_idx() + 1):
        at = ego.obstacle_at_time(k)
        if at is None:
            continue
        if hasattr(other, "obstacle_at_time"):
            if not other.time_start_idx() <= k <= other.time_end_idx():
                continue
            other_at = other.obstacle_at_time(k)
            if other_at is not None and at.collide(other_at):
                return k
        elif at.collide(other):
            return k
    return None


def _obstacle_collision(pps: PlanningProblemSolution, scenario: Scenario) -> str:
    from commonroad_dc.collision.collision_detection.pycrcc_collision_dispatch import create_collision_object

    ego = _ego_object(pps)
    hits = []
    for obstacle in scenario.obstacles:
        k = _first_contact(ego, create_collision_object(obstacle))
        if k is not None:
            hits.append((k, obstacle.obstacle_id))
    if not hits:
        return "collision with an obstacle"
    k, oid = min(hits)
    return f"collision with obstacle {oid} at t = {k * scenario.dt:.1f} s"


def _boundary_collision(pps: PlanningProblemSolution, scenario: Scenario) -> str:
    from commonroad_dc.boundary.boundary import create_road_boundary_obstacle
    from commonroad_dc.collision.collision_detection.pycrcc_collision_dispatch import create_collision_object

    boundary, _ = create_road_boundary_obstacle(scenario, method="triangulation")
    k = _first_contact(_ego_object(pps), create_collision_object(boundary))
    return "leaves the road boundary" + ("" if k is None else f" at t = {k * scenario.dt:.1f} s")


def _agent_collision(pps: PlanningProblemSolution, other: PlanningProblemSolution, dt: float) -> str:
    k = _first_contact(_ego_object(pps), _ego_object(other))
    return f"collision with agent {other.planning_problem_id}" + ("" if k is None else f" at t = {k * dt:.1f} s")


# ----------------------------------------------------------------------- the cache
def default_cache_dir() -> Path:
    """Where verdicts are cached: ``$SIMGAP_CACHE_DIR``, else ``$XDG_CACHE_HOME/simgap``, else
    ``~/.cache/simgap`` (each under ``solution-checks/``)."""
    root = os.environ.get("SIMGAP_CACHE_DIR") or \
        os.path.join(os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache"), "simgap")
    return Path(root) / "solution-checks"


class SolutionCheckCache:
    """Verdicts by the hash of what was checked: the drivability checker's version, the scenario
    file (road, obstacles, planning problems) and every agent's solution (model, type, states)."""

    def __init__(self, folder: Path | None = None):
        self.folder = Path(folder) if folder is not None else default_cache_dir()

    @staticmethod
    def key(solution: Solution, scenario_file: str | Path) -> str:
        h = hashlib.sha256()
        h.update(importlib.metadata.version("commonroad-drivability-checker").encode())
        h.update(Path(scenario_file).read_bytes())
        for pps in sorted(solution.planning_problem_solutions, key=lambda p: p.planning_problem_id):
            h.update(f"{pps.planning_problem_id}:{pps.vehicle_model.name}:{pps.vehicle_type.value}".encode())
            states = pps.trajectory.state_list
            h.update(np.array([[s.time_step, *s.position, s.steering_angle, s.velocity, s.orientation]
                               for s in states], dtype="<f8").tobytes())
        return h.hexdigest()

    def _path(self, key: str) -> Path:
        return self.folder / key[:2] / f"{key}.json"

    def get(self, key: str) -> dict[int, SolutionCheck] | None:
        try:
            raw = json.loads(self._path(key).read_text())
        except (OSError, ValueError):
            return None
        return {int(aid): SolutionCheck(**v) for aid, v in raw.items()}

    def put(self, key: str, checks: dict[int, SolutionCheck]) -> None:
        path = self._path(key)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            atomic_write_text(path, json.dumps({str(aid): asdict(c) for aid, c in checks.items()}))
        except OSError:       # a read-only or full cache only costs the next run its check
            pass


def checked_solution(solution: Solution, scenario: Scenario, problems: PlanningProblemSet,
                     scenario_file: str | Path | None, cache: SolutionCheckCache | None) -> tuple[dict[int, SolutionCheck], bool]:
    """The verdicts on ``solution`` and whether they came from ``cache``."""
    key = SolutionCheckCache.key(solution, scenario_file) if cache is not None and scenario_file is not None \
        and Path(scenario_file).is_file() else None
    if key is not None:
        known = cache.get(key)
        if known is not None and set(known) == {p.planning_problem_id for p in solution.planning_problem_solutions}:
            return known, True
    checks = check_solution(solution, scenario, problems)
    if key is not None and all(c.valid is not None for c in checks.values()):
        cache.put(key, checks)
    return checks, False
