"""A run's scores, written into its record: each agent's closed-loop score with its components,
its driven trajectory as a CommonRoad solution with the solution's cost (cheap: done with the run),
and — after the run is saved — whether that solution is valid (slow, cached, can be skipped).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from commonroad.common.solution import Solution
from commonroad.planning.planning_problem import PlanningProblemSet
from commonroad.scenario.scenario import Scenario

from simgap.cosim.loop import CosimSettings
from simgap.cosim.record import Run
from simgap.evaluate.closed_loop_score import closed_loop_scores
from simgap.evaluate.solution import cost_function_of, run_solution, solution_costs, vehicle_type_of
from simgap.evaluate.validity import SolutionCheckCache, checked_solution
from simgap.vehicles import Vehicle

NO_TRAJECTORY = "the agent drove no step (no trajectory to check)"


def score_run(run: Run, scenario: Scenario, problems: PlanningProblemSet, cosim: CosimSettings,
              planner_vehicle: Vehicle, scenario_file: str | Path | None) -> Solution:
    """Each agent's closed-loop score and solution cost into ``run.agents``; returns the solution."""
    scores = closed_loop_scores(run, scenario, problems, cosim)
    cost_function = cost_function_of(scenario_file, cosim.cost_function)
    solution = run_solution(run, scenario, vehicle_type_of(planner_vehicle), cost_function)
    costs = solution_costs(solution, scenario, problems)
    for agent in run.agents:
        if agent.id in scores:
            score = scores[agent.id]
            agent.score, agent.score_components, agent.score_measures = score.score, score.components, score.measures
        if agent.id in costs:
            cost = costs[agent.id]
            agent.solution_benchmark, agent.solution_cost = cost.benchmark_id, cost.total
            agent.solution_partial_costs, agent.solution_cost_error = cost.partial, cost.error
    return solution


def check_run_solution(run: Run, solution: Solution, scenario: Scenario, problems: PlanningProblemSet,
                       scenario_file: str | Path | None, cache: SolutionCheckCache | None) -> bool:
    """Each agent's solution validity (and the first reason) into ``run.agents``; True when the
    verdicts came from ``cache``."""
    checks, cached = checked_solution(solution, scenario, problems, scenario_file, cache) \
        if solution.planning_problem_solutions else ({}, False)
    for agent in run.agents:
        check = checks.get(agent.id)
        if check is None:
            agent.solution_valid, agent.solution_reason = False, NO_TRAJECTORY
        else:
            agent.solution_valid, agent.solution_reason = check.valid, check.reason
    return cached


@dataclass(frozen=True)
class RunScores:
    """A run's scores as one row of the results store holds them."""

    score: float | None                     # the worst agent's closed-loop score (None: not scored)
    score_components: dict[str, float]      # that agent's components
    solution_valid: bool | None             # every agent's solution valid (None: one was not checked)
    solution_reason: str                    # the first invalid agent's first reason (or why it was not checked)
    solution_cost: float | None             # summed over the agents, as CommonRoad sums a solution's


def worst_scores(run: Run) -> RunScores:
    """A run's scores for its store row: the worst agent's score and components, the solution valid
    when every agent's is (None when one was not checked) with the first reason it is not (or
    could not be checked), and the solution's cost summed over its agents (as CommonRoad sums a
    solution's)."""
    scored = [a for a in run.agents if a.score is not None]
    worst = min(scored, key=lambda a: a.score, default=None)
    validity = [a.solution_valid for a in run.agents]
    # the first reason: of the first invalid agent, else of one that could not be checked (a crash)
    why = next((a for a in run.agents if a.solution_valid is False), None) or \
        next((a for a in run.agents if a.solution_valid is None and a.solution_reason), None)
    costs = [a.solution_cost for a in run.agents]
    many = len(run.agents) > 1
    return RunScores(score=None if worst is None else worst.score,
                     score_components={} if worst is None else dict(worst.score_components),
                     solution_valid=False if False in validity else None if None in validity or not validity else True,
                     solution_reason="" if why is None else (f"agent {why.id}: " if many else "") + why.solution_reason,
                     solution_cost=None if None in costs or not costs else float(sum(costs)))
