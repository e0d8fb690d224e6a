"""The planner study: frenet vs reactive vs idm on the paper's curves (r = 10 m and 50 m, 90 deg;
the left-right curve, the built-in ``s-curve``) and the T-junction (three agents, each driven by
the same planner), in the ideal world and in MuJoCo with the sedan.

Per scenario and planner: agents at the goal per fidelity, mean time to goal, the cross-fidelity
gap (|d_mujoco - d_ideal| by arc length along each agent's route centre, mean and max over agents),
the planning cycles that found no plan, and the wall time per planning call (mean and 95th
percentile over both fidelities). Then the scores: the closed-loop score per fidelity (mean over
agents), its drop and the component that explains most of it, the KS2/SM1 solution cost per
fidelity, the valid solutions per fidelity, and the agents whose solution was valid in the ideal
world and is not in MuJoCo, with the first reason.

Usage: MUJOCO_GL=egl PYTHONPATH=src python bench/planners/planner_study.py [--planners frenet,reactive,idm]
       [--scenarios curve-r10,curve-r50,s-curve,t-junction] [--replan-every 1] [--json]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import asdict, dataclass

import numpy as np

from simgap.cosim import CosimSettings, History, simulate
from simgap.cosim.agents import agents_from_problems
from simgap.evaluate import EvaluationSettings
from simgap.evaluate.compare import compare_histories
from simgap.evaluate.run_evaluation import EvaluationContext, RunEvaluation, evaluate, with_validity
from simgap.evaluate.score_drop import score_drop
from simgap.evaluate.validity import SolutionCheckCache
from simgap.files import BenchmarkResults
from simgap.planning.protocol import PlannerSetup
from simgap.planning.registry import load_planner
from simgap.scenario import build_scenario
from simgap.sim.registry import backend_settings, make_backend
from simgap.sim.settings import road_friction
from simgap.vehicles import load_vehicle

PLANNERS = ("frenet", "reactive", "idm")        # built-in names (simgap.planning.registry), default settings
SCENARIOS = {
    "curve-r10": ("curve", {"radius": 10, "angle": 90}),
    "curve-r50": ("curve", {"radius": 50, "angle": 90}),
    "s-curve": ("s-curve", {}),
    "t-junction": ("t-junction", {}),
}
BACKENDS = ("ideal", "mujoco")


class TimedPlanner:
    """A planner whose every call is timed (wall clock)."""

    def __init__(self, planner):
        self.planner = planner
        self.seconds: list[float] = []

    def plan(self, observed, t, world):
        clock = time.perf_counter()
        try:
            return self.planner.plan(observed, t, world)
        finally:
            self.seconds.append(time.perf_counter() - clock)

    @property
    def failure_reason(self) -> str:
        return getattr(self.planner, "failure_reason", "")


@dataclass
class Row:
    scenario: str
    planner: str
    agents: int
    goals_ideal: int
    goals_mujoco: int
    outcomes_ideal: str
    outcomes_mujoco: str
    time_to_goal_ideal_s: float | None
    time_to_goal_mujoco_s: float | None
    gap_mean_m: float | None
    gap_max_m: float | None
    planner_failures: int           # cycles without a plan, both fidelities, all agents
    planning_calls: int
    ms_per_call_mean: float
    ms_per_call_p95: float
    wall_s: float
    score_ideal: float | None = None        # mean over agents
    score_mujoco: float | None = None
    score_drop: float | None = None          # mean over agents
    lost_most_on: str = ""                   # the component whose loss explains most of the drop
    cost_ideal: float | None = None          # KS2/SM1, summed over agents
    cost_mujoco: float | None = None
    valid_ideal: int = 0                     # agents with a valid solution
    valid_mujoco: int = 0
    broke: str = ""                          # agents valid in the ideal world, invalid in MuJoCo: the reasons
    invalid: str = ""                        # every invalid (or unchecked) solution: world, agent, reason


def _run(template: str, params: dict, planner: str, backend: str, replan_every: int):
    built = build_scenario(template, params)
    scenario, problems = built.scenario, built.problems
    sedan = load_vehicle("sedan")
    agents = agents_from_problems(problems, scenario.dt, sedan)
    planner_class = load_planner(planner)
    timed = {a.id: TimedPlanner(planner_class.build(PlannerSetup(
        a.id, sedan, scenario.lanelet_network, problems.planning_problem_dict[a.id], scenario.dt), None))
        for a in agents}
    cosim = CosimSettings(replan_every=replan_every)
    settings = backend_settings(backend)
    history = simulate(scenario, problems, make_backend(backend, settings), agents, timed, cosim)
    seconds = [s for p in timed.values() for s in p.seconds]
    context = EvaluationContext(scenario, problems, EvaluationSettings(), cosim.offroad_tolerance, cosim.planning_budget_s,
                                road_friction(settings), sedan)
    evaluation = with_validity(evaluate(history, context), history, context, SolutionCheckCache())
    return built, history, evaluation, seconds


def _mean_time_to_goal(history: History) -> float | None:
    times = [a.time_to_goal_s for a in history.agents if a.time_to_goal_s is not None]
    return float(np.mean(times)) if times else None


def _outcomes(history: History) -> str:
    return ",".join(str(a.outcome.value) for a in history.agents)


def study(scenarios: list[str], planners: list[str], replan_every: int) -> list[Row]:
    rows = []
    for name in scenarios:
        template, params = SCENARIOS[name]
        for planner in planners:
            clock = time.perf_counter()
            runs, evaluations, seconds, built = {}, {}, [], None
            for backend in BACKENDS:
                built, runs[backend], evaluations[backend], calls = _run(template, params, planner, backend,
                                                                         replan_every)
                seconds += calls
            comparisons = compare_histories(runs["ideal"], runs["mujoco"], built.scenario, built.problems,
                                            built.sections)
            gaps = [c.lateral_displacement for c in comparisons if np.isfinite(c.lateral_displacement.max)]
            ms = 1000.0 * np.asarray(seconds)
            ideal, mujoco = runs["ideal"], runs["mujoco"]
            scores = _scores(evaluations["ideal"], evaluations["mujoco"])
            rows.append(Row(
                name, planner, len(ideal.agents),
                sum(a.outcome == "goal_reached" for a in ideal.agents),
                sum(a.outcome == "goal_reached" for a in mujoco.agents),
                _outcomes(ideal), _outcomes(mujoco), _mean_time_to_goal(ideal), _mean_time_to_goal(mujoco),
                float(np.mean([g.mean for g in gaps])) if gaps else None,
                float(max(g.max for g in gaps)) if gaps else None,
                sum(a.planner_failures for run in runs.values() for a in run.agents),
                len(ms), float(ms.mean()), float(np.percentile(ms, 95)), time.perf_counter() - clock, **scores))
            print(f"  {name} / {planner}: {rows[-1].wall_s:.0f} s", file=sys.stderr, flush=True)
    return rows


def _scores(ideal: RunEvaluation, mujoco: RunEvaluation) -> dict:
    """The score columns of a row: per fidelity the mean score, the summed cost and the valid count;
    the mean drop and the component that explains most of it; the solutions that broke."""
    weights = EvaluationSettings().score.weights
    pairs = [(a, next(b for b in mujoco.agents if b.id == a.id)) for a in ideal.agents]
    lost: dict[str, float] = {}
    drops = []
    for a, b in pairs:
        drop, losses = score_drop(a, b, weights)
        drops.append(drop)
        for c in losses:
            lost[c.name] = lost.get(c.name, 0.0) + c.regained
    top = max(lost.items(), key=lambda kv: abs(kv[1]), default=("", 0.0))     # lost (or, if negative, gained)
    mean = lambda xs: float(np.mean(xs)) if xs else None                        # noqa: E731
    cost = lambda run: sum(a.solution_cost for a in run.agents) if all(       # noqa: E731
        a.solution_cost is not None for a in run.agents) else None
    return {"score_ideal": mean([a.score for a in ideal.agents]), "score_mujoco": mean([b.score for b in mujoco.agents]),
            "score_drop": mean(drops), "lost_most_on": "-" if abs(top[1]) < 1e-9 else
            f"{top[0]} ({top[1] / len(pairs):+.3f})",
            "cost_ideal": cost(ideal), "cost_mujoco": cost(mujoco),
            "valid_ideal": sum(a.solution_valid is True for a in ideal.agents),
            "valid_mujoco": sum(b.solution_valid is True for b in mujoco.agents),
            "broke": "; ".join(f"agent {b.id}: {b.solution_reason}" for a, b in pairs
                               if a.solution_valid is True and b.solution_valid is False),
            "invalid": "; ".join(f"{world} agent {x.id}: {x.solution_reason}" for world, run in (("ideal", ideal),
                                 ("mujoco", mujoco)) for x in run.agents if x.solution_valid is not True)}


def _fmt(value: float | None, spec: str) -> str:
    return "-" if value is None else format(value, spec)


def print_table(rows: list[Row]) -> None:
    print(f"{'scenario':<11} {'planner':<9} {'goal ideal':>10} {'goal mujoco':>11} {'t_goal ideal':>12} "
          f"{'t_goal mujoco':>13} {'gap mean':>8} {'gap max':>8} {'failed':>6} {'calls':>6} {'ms/call':>8} "
          f"{'p95 ms':>7}")
    for r in rows:
        print(f"{r.scenario:<11} {r.planner:<9} {f'{r.goals_ideal}/{r.agents}':>10} "
              f"{f'{r.goals_mujoco}/{r.agents}':>11} {_fmt(r.time_to_goal_ideal_s, '.1f'):>12} "
              f"{_fmt(r.time_to_goal_mujoco_s, '.1f'):>13} {_fmt(r.gap_mean_m, '.3f'):>8} "
              f"{_fmt(r.gap_max_m, '.3f'):>8} {r.planner_failures:>6} {r.planning_calls:>6} "
              f"{r.ms_per_call_mean:>8.1f} {r.ms_per_call_p95:>7.1f}")
    missed = [r for r in rows if r.goals_ideal < r.agents or r.goals_mujoco < r.agents]
    for r in missed:
        print(f"{r.scenario} / {r.planner}: ideal {r.outcomes_ideal}; mujoco {r.outcomes_mujoco}")
    print(f"\n{'scenario':<11} {'planner':<9} {'score ideal':>11} {'score mujoco':>12} {'drop':>6} {'lost most on':<26} "
          f"{'cost ideal':>10} {'cost mujoco':>11} {'valid ideal':>11} {'valid mujoco':>12}")
    for r in rows:
        print(f"{r.scenario:<11} {r.planner:<9} {_fmt(r.score_ideal, '.3f'):>11} {_fmt(r.score_mujoco, '.3f'):>12} "
              f"{_fmt(r.score_drop, '.3f'):>6} {r.lost_most_on:<26} {_fmt(r.cost_ideal, '.0f'):>10} "
              f"{_fmt(r.cost_mujoco, '.0f'):>11} {f'{r.valid_ideal}/{r.agents}':>11} {f'{r.valid_mujoco}/{r.agents}':>12}")
    print("\nlost most on: the component whose loss explains most of the drop (its mean share; negative: gained)")
    for r in rows:
        if r.broke:
            print(f"{r.scenario} / {r.planner}: valid in the ideal world, invalid in MuJoCo: {r.broke}")
    for r in rows:
        if r.invalid:
            print(f"{r.scenario} / {r.planner}: invalid: {r.invalid}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--planners", default=",".join(PLANNERS))
    parser.add_argument("--scenarios", default=",".join(SCENARIOS))
    parser.add_argument("--replan-every", type=int, default=1, help="replan every N steps (the loop's default: 1)")
    parser.add_argument("--json", nargs="?", const="-", metavar="FILE",
                        help="alone: print the rows as JSON instead of the table; with FILE: print the table and write "
                             "the rows, with commit, date, machine and load, to this results file")
    args = parser.parse_args()
    results_file = BenchmarkResults()
    planners, scenarios = args.planners.split(","), args.scenarios.split(",")
    for name, known in ((planners, PLANNERS), (scenarios, SCENARIOS)):
        unknown = sorted(set(name) - set(known))
        if unknown:
            parser.error(f"unknown {unknown}; choose from {', '.join(known)}")
    start = time.perf_counter()
    rows = study(scenarios, planners, args.replan_every)
    if args.json == "-":
        print(json.dumps([asdict(r) for r in rows], indent=2))
        return
    print_table(rows)
    print(f"\n{len(rows) * len(BACKENDS)} runs in {time.perf_counter() - start:.0f} s "
          f"(replan every {args.replan_every} step(s); sedan; gap = |d_mujoco - d_ideal| by arc length)")
    if args.json:
        results_file.write(args.json, {"arguments": vars(args), "replan_every": args.replan_every, "vehicle": "sedan",
                                       "rows": [asdict(r) for r in rows]})


if __name__ == "__main__":
    main()
