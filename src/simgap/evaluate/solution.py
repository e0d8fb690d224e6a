"""Each agent's driven trajectory as a CommonRoad solution, and its cost.

A run's solution (``solution.xml`` in the run directory, commonroad-io's `Solution`, readable by
`CommonRoadSolutionReader`) holds one planning-problem solution per agent: the agent's driven
states (centre position, heading, speed, steering angle) on the scenario's time steps, for the
vehicle model and type the planner plans with — the kinematic single-track model (KS) of the
planner's vehicle's CommonRoad type (``commonroad_vehicle_type`` of its data file; type 2, the
BMW 320i every catalogue vehicle's planner limits come from, when it names none) — and a cost
function: the one the scenario's benchmark ID names (``KS2:SM1:DEU_…``), else
``evaluation.cost_function``.

The cost is commonroad-drivability-checker's `CostFunctionEvaluator`, every partial cost with its
weight. Whether the solution is valid is `simgap.evaluate.solution_check` (slow: it runs after
the run is saved, in a process of its own, cached: `simgap.evaluate.validity`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from commonroad.common.solution import (
    CommonRoadSolutionWriter,
    CostFunction,
    PlanningProblemSolution,
    Solution,
    VehicleModel,
    VehicleType,
)
from commonroad.planning.planning_problem import PlanningProblemSet
from commonroad.scenario.scenario import Scenario
from commonroad.scenario.state import KSState
from commonroad.scenario.trajectory import Trajectory as CrTrajectory

from simgap.cosim.history import History
from simgap.evaluate.settings import CostFunctionId
from simgap.trajectory import Trajectory
from simgap.vehicles import Vehicle

SOLUTION_FILE = "solution.xml"
VEHICLE_MODEL = VehicleModel.KS          # the planners' model: kinematic single track
DEFAULT_VEHICLE_TYPE = VehicleType.BMW_320i

#: CommonRoad's partial cost ids, in its words (commonroad_dc.costs.evaluation.PartialCostFunction)
PARTIAL_COSTS = {"A": "acceleration", "J": "jerk", "Jlat": "lateral jerk", "Jlon": "longitudinal jerk",
                 "SA": "steering angle", "SR": "steering rate", "Y": "yaw rate", "LC": "lane centre offset",
                 "V": "velocity offset", "Vlon": "longitudinal velocity offset", "O": "orientation offset",
                 "D": "distance to obstacles", "L": "path length", "T": "time", "ID": "inverse duration"}


@dataclass(frozen=True)
class PartialCost:
    """One term of a CommonRoad cost function: its value (unweighted) and its weight."""

    cost: float
    weight: float

    @property
    def weighted(self) -> float:
        return self.cost * self.weight


@dataclass(frozen=True)
class SolutionCost:
    """The cost of one agent's solution: the total and every partial cost with its weight (None
    and the evaluator's error when it could not evaluate it)."""

    benchmark_id: str
    total: float | None
    partial: dict[str, PartialCost]
    error: str = ""


def vehicle_type_of(vehicle: Vehicle) -> VehicleType:
    """The CommonRoad vehicle type a planner's vehicle stands for (type 2 when its file names none)."""
    return VehicleType(vehicle.commonroad_vehicle_type) if vehicle.commonroad_vehicle_type else DEFAULT_VEHICLE_TYPE


def cost_function_of(scenario_file: str | Path | None, default: CostFunctionId) -> CostFunctionId:
    """The cost function the scenario's benchmark ID names (``KS2:SM1:DEU_A9-1_1_T-1:2020a``), else
    ``default``. Read from the file's header: commonroad-io keeps only the scenario part of the ID."""
    if scenario_file is None or not Path(scenario_file).is_file():
        return default
    with open(scenario_file, encoding="utf-8", errors="replace") as f:
        head = f.read(4096)
    match = re.search(r'benchmarkID\s*=\s*"([^"]*)"', head)
    tokens = match.group(1).split(":") if match else []
    return next((CostFunctionId(t) for t in tokens if t in CostFunctionId.__members__), default)


def solution_trajectory(driven: Trajectory, dt: float) -> CrTrajectory:
    """A driven trajectory as CommonRoad KS states on the scenario's time steps."""
    steps = np.rint(driven.t / dt).astype(int)
    states = [KSState(time_step=int(k), position=np.array([x, y]), steering_angle=float(steer), velocity=float(v),
                      orientation=float(yaw))
              for k, x, y, steer, v, yaw in zip(steps, driven.x, driven.y, driven.steer, driven.v, driven.yaw)]
    return CrTrajectory(int(steps[0]), states)


def run_solution(history: History, scenario: Scenario, vehicle_type: VehicleType,
                 cost_function: CostFunctionId) -> Solution:
    """Every agent's driven trajectory (with at least two states) as one CommonRoad solution."""
    cost = CostFunction[cost_function.value]
    driven = history.driven
    solutions = [PlanningProblemSolution(aid, VEHICLE_MODEL, vehicle_type, cost,
                                         solution_trajectory(driven[aid], history.dt))
                 for aid in sorted(driven) if len(driven[aid]) >= 2]
    return Solution(scenario.scenario_id, solutions, date=None)


def benchmark_id(solution: Solution, pps: PlanningProblemSolution) -> str:
    """The benchmark ID of one agent's part of a solution (``KS2:SM1:ZAM_…:2020a``)."""
    return Solution(solution.scenario_id, [pps], date=None).benchmark_id


def solution_xml(solution: Solution) -> str:
    return CommonRoadSolutionWriter(solution).dump(pretty=True)


def solution_costs(solution: Solution, scenario: Scenario, problems: PlanningProblemSet) -> dict[int, SolutionCost]:
    """Each agent's cost by `CostFunctionEvaluator`. Where the evaluator fails — its route matching
    on a trajectory it cannot place on a lane; the distance-to-obstacles term (D, in SA1, WX1 and
    TR1), which commonroad-drivability-checker 2025.3.1 computes with ``np.math``, gone in numpy 2 —
    the cost is None and the error says why; so too where a term overflows (a planner's speeds or
    accelerations out of any physical range), which numpy would otherwise only warn of."""
    from commonroad_dc.costs.evaluation import CostFunctionEvaluator

    out = {}
    for pps in solution.planning_problem_solutions:
        evaluator = CostFunctionEvaluator(pps.cost_function, pps.vehicle_type)
        bid = benchmark_id(solution, pps)
        try:
            with np.errstate(all="ignore"):
                result = evaluator.evaluate_pp_solution(scenario,
                                                        problems.planning_problem_dict[pps.planning_problem_id],
                                                        pps.trajectory)
        except Exception as exc:     # the library's own failure: this agent has no cost, the run goes on
            cause = f" ({type(exc.__cause__).__name__}: {exc.__cause__})" if exc.__cause__ else ""
            out[pps.planning_problem_id] = SolutionCost(bid, None, {}, f"{exc}{cause}")
            continue
        overflowed = [p.value for p, c in result.partial_costs.items() if not np.isfinite(c)]
        if overflowed or not np.isfinite(result.total_costs):
            out[pps.planning_problem_id] = SolutionCost(
                bid, None, {}, f"the cost is not finite: its term{'s' * (len(overflowed) > 1)} "
                               f"{', '.join(overflowed) or 'total'} overflowed (speeds or accelerations out of any "
                               f"physical range)")
            continue
        out[pps.planning_problem_id] = SolutionCost(
            bid, float(result.total_costs),
            {p.value: PartialCost(float(c), float(result.weights[p])) for p, c in result.partial_costs.items()})
    return out
