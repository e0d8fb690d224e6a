"""Whether each agent's solution is valid, by commonroad-drivability-checker's solution checker, and
the first reason when it is not.

The checks are the library's own (`commonroad_dc.feasibility.solution_checker`), in the order its
``valid_solution`` runs them, on each agent's part of the solution alone: the goal reached, the
start at the planning problem's initial state, no collision with the scenario's obstacles, inside
the road boundary, no collision with another agent, and feasible for the vehicle model (its
inputs reconstructed state by state). The first that fails is the reason; the checks after it are
not run. Where the library only says *that* something failed, the time (and the obstacle) is
located with its own collision objects.

The library's road boundary is a triangulation of the road's outside, a quarter of a second to build
per scenario (and it crashes the process on some curves): it is built only for a trajectory with a
footprint within `ROAD_INTERIOR_MARGIN_M` of the road's edge, or on a road whose lanelets overlap.

The library's feasibility check is slow (milliseconds per state); a KS trajectory takes
`simgap.evaluate.feasibility`'s fast path, with the library's verdicts, and the library checks
only the transitions near a limit. Runs are checked after they are saved, in a process of their
own, with their verdicts cached (`simgap.evaluate.validity`).
"""

from __future__ import annotations

import atexit
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass

from commonroad.common.solution import PlanningProblemSolution, Solution
from commonroad.planning.planning_problem import PlanningProblemSet
from commonroad.scenario.scenario import Scenario

from simgap.evaluate.feasibility import ks_feasibility


@dataclass(frozen=True)
class SolutionCheck:
    """One agent's verdict: valid (None: could not be checked) and why not."""

    valid: bool | None
    reason: str = ""


Stage = Callable[[str], None]


def check_solution(solution: Solution, scenario: Scenario, problems: PlanningProblemSet,
                   on_stage: Stage = lambda _: None) -> dict[int, SolutionCheck]:
    """The verdict on each agent's part of ``solution`` (``on_stage`` is told each check as it starts)."""
    return {pps.planning_problem_id: check_agent(pps, solution, scenario, problems, on_stage)
            for pps in solution.planning_problem_solutions}


def check_agent(pps: PlanningProblemSolution, solution: Solution, scenario: Scenario, problems: PlanningProblemSet,
                on_stage: Stage = lambda _: None) -> SolutionCheck:
    """The verdict on one agent's part of ``solution`` (None: the library raised on it)."""
    try:
        return _check_agent(pps, solution, scenario, problems,
                            lambda check: on_stage(f"agent {pps.planning_problem_id}'s {check} check"))
    except Exception as exc:     # the library failed on this input: no verdict, the run goes on
        return SolutionCheck(None, f"the check raised {type(exc).__name__}: {_first_line(exc)}")


def _check_agent(pps: PlanningProblemSolution, solution: Solution, scenario: Scenario,
                 problems: PlanningProblemSet, on_stage: Stage) -> SolutionCheck:
    from commonroad_dc.feasibility import solution_checker as checker

    pid = pps.planning_problem_id
    alone = Solution(solution.scenario_id, [pps], date=None)
    problem_set = PlanningProblemSet([problems.planning_problem_dict[pid]])
    on_stage("goal")
    try:
        checker.goal_reached(scenario, problem_set, alone)
    except checker.GoalNotReachedException:
        end = pps.trajectory.state_list[-1].time_step * scenario.dt
        return SolutionCheck(False, f"goal not reached (the trajectory ends at t = {end:.1f} s)")
    on_stage("initial state")
    try:
        checker.starts_at_correct_state(alone, problem_set)
    except checker.SolutionCheckerException as exc:
        return SolutionCheck(False, "does not start at the planning problem's initial state: " + _first_line(exc))
    on_stage("obstacle collision")
    try:
        checker.obstacle_collision(scenario, problem_set, alone)
    except checker.CollisionException:
        return SolutionCheck(False, _obstacle_collision(pps, scenario))
    on_stage("road boundary")
    if not _well_inside_the_road(scenario, problem_set, pps):
        ego = checker._create_pp_solution_collision_object(problem_set, pps, scenario.dt)
        if _road_boundary(scenario).collide(ego):           # the library's boundary_collision, its boundary kept
            return SolutionCheck(False, _boundary_collision(pps, scenario))
    on_stage("collision between agents")
    others = [o for o in solution.planning_problem_solutions if o.planning_problem_id != pid]
    for other in others:
        pair = Solution(solution.scenario_id, [pps, other], date=None)
        pair_problems = PlanningProblemSet([problems.planning_problem_dict[pid],
                                            problems.planning_problem_dict[other.planning_problem_id]])
        try:
            checker.ego_collision(scenario, pair_problems, pair)
        except checker.CollisionException:
            return SolutionCheck(False, _agent_collision(pps, other, scenario.dt))
    on_stage("feasibility")
    try:
        k = _infeasible_step(pps, alone, scenario.dt, problem_set)
    except checker.SolutionCheckerException as exc:
        return SolutionCheck(False, f"infeasible for {_model(pps)}: " + _first_line(exc.__cause__ or exc))
    if k is not None:
        return SolutionCheck(False, f"infeasible for {_model(pps)} at t = {(k + 1) * scenario.dt:.1f} s (no input "
                                    f"reaches that state from the one at t = {k * scenario.dt:.1f} s)")
    return SolutionCheck(True)


BOUNDARIES_KEPT = 8


class _PerScenario:
    """What was built from each of the last `BOUNDARIES_KEPT` scenario objects checked: the checker
    process reads a scenario file once for all the runs on it (`simgap.evaluate.validity`)."""

    def __init__(self, build: Callable[[Scenario], object]):
        self._build = build
        self._kept: OrderedDict[int, tuple[Scenario, object]] = OrderedDict()
        atexit.register(self._kept.clear)      # freed before the interpreter tears the bindings down

    def __call__(self, scenario: Scenario):
        key = id(scenario)
        if key in self._kept and self._kept[key][0] is scenario:
            self._kept.move_to_end(key)
            return self._kept[key][1]
        value = self._build(scenario)
        self._kept[key] = (scenario, value)
        while len(self._kept) > BOUNDARIES_KEPT:
            self._kept.popitem(last=False)
        return value


def _construct_road_boundary(scenario: Scenario):
    """The library's road-boundary collision checker of ``scenario`` (its triangulation, a quarter
    of a second to build)."""
    from commonroad_dc.feasibility import solution_checker as checker

    return checker._construct_boundary_checker(scenario)


# A footprint this far inside the road cannot touch the library's road boundary, which lies outside
# the lanelets; the boundary is built only for footprints nearer the edge, and on roads whose
# lanelets overlap (junctions), where it may not.
ROAD_INTERIOR_MARGIN_M = 0.05


def _construct_road_interior(scenario: Scenario):
    """The union of ``scenario``'s lanelets shrunk by `ROAD_INTERIOR_MARGIN_M` (prepared); None when
    lanelets overlap or a lanelet's polygon is not simple."""
    import shapely
    from shapely.ops import unary_union

    polygons = [shapely.Polygon(lanelet.polygon.vertices) for lanelet in scenario.lanelet_network.lanelets]
    if not polygons or not all(p.is_valid for p in polygons):
        return None
    road = unary_union(polygons)
    if sum(p.area for p in polygons) - road.area > 1e-6 * road.area:      # a lanelet overlaps another
        return None
    interior = road.buffer(-ROAD_INTERIOR_MARGIN_M)
    shapely.prepare(interior)
    return interior


_road_boundary = _PerScenario(_construct_road_boundary)
_road_interior = _PerScenario(_construct_road_interior)


def _well_inside_the_road(scenario: Scenario, problem_set: PlanningProblemSet, pps: PlanningProblemSolution) -> bool:
    """Every footprint of the trajectory the library checks (its states, its vehicle's rectangle)
    lies in `_road_interior`."""
    import numpy as np
    import shapely
    from commonroad_dc.feasibility import solution_checker as checker

    interior = _road_interior(scenario)
    if interior is None:
        return False
    dynamics, trajectory = checker._simulate_trajectory_if_input_vector(problem_set, pps, scenario.dt)
    shape = dynamics.shape
    if type(shape).__name__ != "Rectangle" or np.any(np.asarray(shape.center, dtype=float)) or shape.orientation:
        return False
    xy = np.array([st.position for st in trajectory.state_list], dtype=float)
    yaw = np.array([st.orientation for st in trajectory.state_list], dtype=float)
    c, s = np.cos(yaw), np.sin(yaw)
    corners = np.stack([np.stack([xy[:, 0] + a * c - b * s, xy[:, 1] + a * s + b * c], axis=1)
                        for a, b in ((shape.length / 2, shape.width / 2), (shape.length / 2, -shape.width / 2),
                                     (-shape.length / 2, -shape.width / 2), (-shape.length / 2, shape.width / 2))],
                       axis=1)
    return bool(shapely.contains(interior, shapely.polygons(corners)).all())


def _infeasible_step(pps: PlanningProblemSolution, alone: Solution, dt: float,
                     problem_set: PlanningProblemSet) -> int | None:
    """The library's feasibility verdict on one agent's trajectory: the time step whose transition
    is not feasible, None when every one is. A KS trajectory through `simgap.evaluate.feasibility`'s
    fast path (the same verdicts), any other by the library's `solution_feasible`."""
    from commonroad.common.solution import TrajectoryType, VehicleModel
    from commonroad_dc.feasibility import solution_checker as checker
    from commonroad_dc.feasibility.feasibility_checker import StateTransitionException
    from commonroad_dc.feasibility.vehicle_dynamics import VehicleDynamics

    if pps.vehicle_model == VehicleModel.KS and pps.trajectory_type not in (TrajectoryType.Input,
                                                                            TrajectoryType.PMInput):
        try:
            verdict = ks_feasibility(pps.trajectory, VehicleDynamics.from_model(pps.vehicle_model, pps.vehicle_type),
                                     dt)
        except StateTransitionException as exc:     # as the library's solution_feasible words it
            raise checker.SolutionCheckerException(f"Solution is not feasible on planning problem solution "
                                                   f"{pps.planning_problem_id}.") from exc
        return None if verdict.feasible else verdict.infeasible_from
    feasible, inputs, _ = checker.solution_feasible(alone, dt, problem_set)[pps.planning_problem_id]
    return None if feasible else inputs.state_list[-1].time_step


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
