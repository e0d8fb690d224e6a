"""`evaluate(history, context) -> RunEvaluation`: every metric of one run, computed here and
nowhere else.

Per agent: when it reached its goal, how far it drove, how close it came to other road users and
how far beyond the road (`simgap.evaluate.closest_approach`), the wall time of its planning calls
and the latency of its plans, how well the car tracked its plans (`AgentTracking`), its
closed-loop score, its solution's cost and — after the run is saved, slow and cached — whether its
solution is valid (`with_validity`). Per run: the scalars a search looks at
(`simgap.evaluate.run_metrics`) and, with several agents, the criticality of every pair
(`with_criticality`: commonroad-crime, slow). The
comparison of two runs of one scenario is `simgap.evaluate.compare.compare_histories`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from enum import StrEnum
from pathlib import Path

import numpy as np
from commonroad.common.solution import Solution
from commonroad.planning.planning_problem import PlanningProblemSet
from commonroad.scenario.scenario import Scenario

from simgap.cosim.history import AgentHistory, History
from simgap.evaluate.closed_loop_score import closed_loop_scores
from simgap.evaluate.closest_approach import closest_approaches
from simgap.evaluate.criticality import PairCriticality, run_criticality
from simgap.evaluate.errors import Aggregate, Comfort, comfort, tracking_errors
from simgap.evaluate.run_metrics import RouteMeasures, route_measures, run_metrics
from simgap.evaluate.settings import EvaluationSettings
from simgap.evaluate.solution import PartialCost, cost_function_of, run_solution, solution_costs, vehicle_type_of
from simgap.evaluate.validity import SolutionCheckCache, checked_solution
from simgap.scenario.obstacles import RecordedObstacle
from simgap.scenario.relief import Surface
from simgap.scenario.road_frame import DrivableArea
from simgap.vehicles import Vehicle

NO_TRAJECTORY = "the agent drove no step (no trajectory to check)"


class SolutionCheckSource(StrEnum):
    """Where a run's validity verdicts came from."""

    CHECKED = "checked"          # the checker ran on this run's solution
    CACHED = "cached"            # an earlier check of the same solution on the same scenario file


@dataclass(frozen=True)
class AgentTracking:
    """Planned versus driven within one run, for one agent: position, orientation and velocity
    errors against the plan in force, their lateral and longitudinal parts in the route's frame,
    the comfort peaks, and how far the footprint reached beyond the route's lanes."""

    position: Aggregate
    orientation: Aggregate
    velocity: Aggregate
    lateral: Aggregate
    longitudinal: Aggregate
    comfort: Comfort
    lane_excursion_m: float


@dataclass(frozen=True)
class AgentEvaluation:
    """One agent's metrics and scores."""

    id: int
    time_to_goal_s: float | None
    distance_m: float
    min_distance_to_traffic_m: float | None     # None: no other road user was ever in the world with it
    max_road_excursion_m: float = 0.0
    planning_calls: int = 0
    planning_mean_s: float | None = None        # wall time per planning call
    planning_p95_s: float | None = None
    planning_max_s: float | None = None
    planning_over_budget: int = 0               # calls longer than the loop's planning_budget_s
    plan_latency_mean_s: float | None = None    # how long after its planning time a plan reached the car
    plan_latency_max_s: float | None = None
    tracking: AgentTracking | None = None       # None: a run recorded before tracking was evaluated with it
    score: float | None = None                  # closed-loop score in [0, 1], built like nuPlan's CLS
    score_components: Mapping[str, float] = field(default_factory=dict)   # its multipliers and weighted terms
    score_measures: Mapping[str, float | None] = field(default_factory=dict)   # what they were computed from
    solution_benchmark: str = ""                # the solution's benchmark ID: model+type:cost function:scenario
    solution_cost: float | None = None          # the cost function's total
    solution_partial_costs: Mapping[str, PartialCost] = field(default_factory=dict)   # by CommonRoad's term id
    solution_cost_error: str = ""               # why the cost could not be evaluated
    solution_valid: bool | None = None          # by commonroad-drivability-checker; None: not checked
    solution_reason: str = ""                   # the first reason it is invalid


@dataclass(frozen=True)
class RunEvaluation:
    """Every metric of one run."""

    agents: tuple[AgentEvaluation, ...]
    metrics: Mapping[str, float] = field(default_factory=dict)   # simgap.evaluate.run_metrics, worst over agents
    criticality: tuple[PairCriticality, ...] = ()                # per ordered agent pair (several agents)
    solution_check: SolutionCheckSource | None = None            # None: validity not checked

    def __post_init__(self) -> None:
        object.__setattr__(self, "metrics", dict(self.metrics))

    def agent(self, agent_id: int) -> AgentEvaluation:
        return next(a for a in self.agents if a.id == agent_id)


@dataclass(frozen=True)
class EvaluationContext:
    """What a run is evaluated against: its scenario (as the loop ran it), the evaluation's settings
    (cost function, score settings), the two loop settings its figures are measured against (how far
    the footprint may leave the road, the planning calls' budget), the road's friction and relief, the
    vehicle the planner assumed (the solution's vehicle type), and the scenario's file (its benchmark ID)."""

    scenario: Scenario
    problems: PlanningProblemSet
    settings: EvaluationSettings
    offroad_tolerance_m: float           # the loop's ``offroad_tolerance``
    planning_budget_s: float | None      # the loop's ``planning_budget_s``
    road_friction: float
    planner_vehicle: Vehicle
    relief: Surface | None = None
    scenario_file: Path | None = None
    road: DrivableArea | None = None     # the drivable area widened by ``offroad_tolerance_m``, as the loop judged
                                         # footprints against it (built again when not given)
    obstacles: tuple[RecordedObstacle, ...] | None = None     # the scenario's (made again when not given)


@dataclass(frozen=True)
class PlanningTimes:
    """Calls, mean, 95th percentile and maximum of the wall times [s] of one agent's planning calls
    (None: no call), and how many took longer than the budget."""

    calls: int = 0
    mean_s: float | None = None
    p95_s: float | None = None
    max_s: float | None = None
    over_budget: int = 0


def planning_times(call_s: tuple[float, ...], budget_s: float | None) -> PlanningTimes:
    """The `PlanningTimes` of the wall times ``call_s``, against ``budget_s`` (None: no budget)."""
    if not call_s:
        return PlanningTimes()
    times = np.asarray(call_s)
    return PlanningTimes(len(times), round(float(times.mean()), 6), round(float(np.percentile(times, 95)), 6),
                         round(float(times.max()), 6),
                         0 if budget_s is None else int(sum(t > budget_s for t in call_s)))


def tracking_of(agent: AgentHistory, route: RouteMeasures) -> AgentTracking:
    """How well ``agent``'s car followed its plans (``route``: its measures in its route's frame)."""
    errs = tracking_errors(agent.driven, list(agent.plans))
    frenet = route.tracking
    return AgentTracking(Aggregate.of(errs.position), Aggregate.of(errs.orientation), Aggregate.of(errs.velocity),
                         Aggregate.of(frenet.lateral if frenet else []), Aggregate.of(frenet.longitudinal if frenet else []),
                         comfort(agent.driven), route.lane_excursion_m)


def solution_of(history: History, context: EvaluationContext) -> Solution:
    """Every agent's driven trajectory as one CommonRoad solution (``solution.xml``)."""
    return run_solution(history, context.scenario, vehicle_type_of(context.planner_vehicle),
                        cost_function_of(context.scenario_file, context.settings.cost_function))


def evaluate(history: History, context: EvaluationContext) -> RunEvaluation:
    """Every metric and score of the run ``history`` records, but its solution's validity."""
    approaches = closest_approaches(history, context.scenario, context.offroad_tolerance_m, context.road,
                                    context.obstacles)
    routes = {a.id: route_measures(a, context.scenario, context.problems.planning_problem_dict.get(a.id))
              for a in history.agents}
    excursions = {aid: round(a.max_road_excursion_m, 3) for aid, a in approaches.items()}   # as recorded
    scores = closed_loop_scores(history, context.scenario, context.problems, context.settings.score,
                                context.offroad_tolerance_m, excursions, obstacles=context.obstacles)
    costs = solution_costs(solution_of(history, context), context.scenario, context.problems)
    agents = []
    for a in history.agents:
        approach, score, cost = approaches[a.id], scores.get(a.id), costs.get(a.id)
        latencies, times = a.plan_latency_s, planning_times(a.planning_call_s, context.planning_budget_s)
        agents.append(AgentEvaluation(
            id=a.id,
            time_to_goal_s=None if a.time_to_goal_s is None else round(a.time_to_goal_s, 6),
            distance_m=round(a.driven.path_length(), 3),
            min_distance_to_traffic_m=None if approach.min_distance_m is None else round(approach.min_distance_m, 3),
            max_road_excursion_m=round(approach.max_road_excursion_m, 3),
            planning_calls=times.calls, planning_mean_s=times.mean_s, planning_p95_s=times.p95_s,
            planning_max_s=times.max_s, planning_over_budget=times.over_budget,
            plan_latency_mean_s=round(float(np.mean(latencies)), 6) if latencies else None,
            plan_latency_max_s=round(max(latencies), 6) if latencies else None,
            tracking=tracking_of(a, routes[a.id]),
            score=None if score is None else score.score,
            score_components={} if score is None else score.components,
            score_measures={} if score is None else score.measures,
            solution_benchmark="" if cost is None else cost.benchmark_id,
            solution_cost=None if cost is None else cost.total,
            solution_partial_costs={} if cost is None else cost.partial,
            solution_cost_error="" if cost is None else cost.error))
    return RunEvaluation(tuple(agents),
                         run_metrics(history, context.scenario, context.problems, context.road_friction,
                                     context.relief, routes))


def with_criticality(evaluation: RunEvaluation, history: History, context: EvaluationContext) -> RunEvaluation:
    """``evaluation`` with the criticality of every pair of agents (commonroad-crime: TTC, THW, BTN,
    STN; none for one agent; about a second per pair and minute of a run, and the library's import)."""
    return replace(evaluation, criticality=run_criticality(history, context.scenario))


def with_validity(evaluation: RunEvaluation, history: History, context: EvaluationContext,
                  cache: SolutionCheckCache | None) -> RunEvaluation:
    """``evaluation`` with every agent's solution checked by commonroad-drivability-checker (the
    verdicts from ``cache`` where it has them)."""
    solution = solution_of(history, context)
    checks, cached = checked_solution(solution, context.scenario, context.problems, context.scenario_file, cache) \
        if solution.planning_problem_solutions else ({}, False)
    agents = []
    for a in evaluation.agents:
        check = checks.get(a.id)
        agents.append(replace(a, solution_valid=False, solution_reason=NO_TRAJECTORY) if check is None else
                      replace(a, solution_valid=check.valid, solution_reason=check.reason))
    return replace(evaluation, agents=tuple(agents),
                   solution_check=SolutionCheckSource.CACHED if cached else SolutionCheckSource.CHECKED)


@dataclass(frozen=True)
class RunScores:
    """A run's scores over its agents, as one row of the results store holds them."""

    score: float | None                     # the worst agent's closed-loop score (None: not scored)
    score_components: dict[str, float]      # that agent's components
    solution_valid: bool | None             # every agent's solution valid (None: one was not checked)
    solution_reason: str                    # the first invalid agent's first reason (or why it was not checked)
    solution_cost: float | None             # summed over the agents, as CommonRoad sums a solution's


def worst_scores(evaluation: RunEvaluation) -> RunScores:
    """The worst agent's score and components, the solution valid when every agent's is (None when
    one was not checked) with the first reason it is not (or could not be checked), and the
    solution's cost summed over its agents (as CommonRoad sums a solution's)."""
    agents = evaluation.agents
    scored = [a for a in agents if a.score is not None]
    worst = min(scored, key=lambda a: math.inf if a.score is None else a.score, default=None)
    validity = [a.solution_valid for a in agents]
    # the first reason: of the first invalid agent, else of one that could not be checked (a crash)
    why = next((a for a in agents if a.solution_valid is False), None) or \
        next((a for a in agents if a.solution_valid is None and a.solution_reason), None)
    costs = [a.solution_cost for a in agents if a.solution_cost is not None]
    many = len(agents) > 1
    return RunScores(score=None if worst is None else worst.score,
                     score_components={} if worst is None else dict(worst.score_components),
                     solution_valid=False if False in validity else None if None in validity or not validity else True,
                     solution_reason="" if why is None else (f"agent {why.id}: " if many else "") + why.solution_reason,
                     solution_cost=None if len(costs) < len(agents) or not costs else float(sum(costs)))
