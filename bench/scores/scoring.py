"""What scoring a run costs: the closed-loop score, the solution's cost, and the solution's validity
check, against the run's own wall time, on a paper curve (ideal and MuJoCo) and on a recorded-like
highway with traffic (and on CommonRoad files of your own with ``--files``).

Per run: the run's wall time (the loop), then each scoring phase timed in a warm process (the
imports of commonroad_dc's cost module and scipy.signal, once per process, are reported apart):
the score, the cost, their share of the run's wall time; the validity check from scratch and per
state, and again from the cache (the same trajectory checked twice); the verdict and the cost.

    MUJOCO_GL=egl PYTHONPATH=src python bench/scores/scoring.py
    MUJOCO_GL=egl PYTHONPATH=src python bench/scores/scoring.py --files /work/corpus/recorded/x/USA_US101-1_1_T-1.xml
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

import numpy as np
from commonroad.common.util import Interval
from commonroad.geometry.shape import Rectangle
from commonroad.planning.goal import GoalRegion
from commonroad.planning.planning_problem import PlanningProblem, PlanningProblemSet
from commonroad.prediction.prediction import TrajectoryPrediction
from commonroad.scenario.lanelet import Lanelet, LaneletNetwork
from commonroad.scenario.obstacle import DynamicObstacle, ObstacleType
from commonroad.scenario.scenario import Scenario, ScenarioID
from commonroad.scenario.state import CustomState, InitialState, KSState
from commonroad.scenario.trajectory import Trajectory as CrTrajectory

from simgap.cosim import CosimSettings
from simgap.evaluate import EvaluationSettings
from simgap.evaluate.closed_loop_score import closed_loop_scores
from simgap.evaluate.solution import cost_function_of, run_solution, solution_costs, vehicle_type_of
from simgap.evaluate.validity import SolutionCheckCache, checked_solution
from simgap.experiment.single_run import RunRequest, execute
from simgap.files import BenchmarkResults
from simgap.scenario import build_scenario, load_scenario, write_scenario
from simgap.scenario.files import write_xml
from simgap.vehicles import load_vehicle

DT = 0.1
LANE = 3.5


def recorded_like_highway(folder: Path, cars: int = 24, seed: int = 0) -> Path:
    """A 3-lane, 600 m highway with ``cars`` recorded cars at 20-30 m/s (NGSIM/highD-like), some
    changing lanes, and an ego in the middle lane with a highD-style goal (a box and a time window)."""
    rng = np.random.default_rng(seed)
    scenario = Scenario(DT, scenario_id=ScenarioID(country_id="DEU", map_name="SimgapHighway", map_id=1))
    x = np.linspace(0.0, 600.0, 40)
    lanelets = []
    for lane in range(3):
        right, left = lane * LANE, (lane + 1) * LANE
        lid = 10 * (lane + 1)
        lanelets.append(Lanelet(np.stack([x, np.full_like(x, left)], 1), np.stack([x, np.full_like(x, left - LANE / 2)], 1),
                                np.stack([x, np.full_like(x, right)], 1), lid,
                                adjacent_left=lid + 10 if lane < 2 else None, adjacent_left_same_direction=True,
                                adjacent_right=lid - 10 if lane else None, adjacent_right_same_direction=True))
    scenario.add_objects(LaneletNetwork.create_from_lanelet_list(lanelets))
    steps = 200
    for i in range(cars):
        lane = i % 3
        x0 = 15.0 + 25.0 * (i // 3) + rng.uniform(-5, 5)
        if lane == 1 and abs(x0 - 60.0) < 25.0:
            x0 += 50.0                                  # room for the ego
        v = rng.uniform(20.0, 30.0)
        change = 0
        if rng.random() < 0.25:                         # a lane change to a neighbouring lane
            change = 1 if lane == 0 else -1 if lane == 2 else int(rng.choice([-1, 1]))
        t = DT * np.arange(steps + 1)
        ramp = np.clip((t - 3.0) / 4.0, 0.0, 1.0)
        y = (lane + 0.5) * LANE + change * LANE * ramp ** 2 * (3 - 2 * ramp)
        xs = x0 + v * t
        yaw = np.arctan2(np.gradient(y, DT), v)
        states = [KSState(time_step=k, position=np.array([xs[k], y[k]]), orientation=float(yaw[k]), velocity=v,
                          steering_angle=0.0) for k in range(1, steps + 1)]
        init = InitialState(position=np.array([xs[0], y[0]]), orientation=float(yaw[0]), velocity=v, time_step=0)
        shape = Rectangle(4.6, 1.9)
        scenario.add_objects(DynamicObstacle(100 + i, ObstacleType.CAR, shape, init,
                                             TrajectoryPrediction(CrTrajectory(1, states), shape)))
    start = InitialState(position=np.array([60.0, 1.5 * LANE]), orientation=0.0, velocity=22.0, acceleration=0.0,
                         yaw_rate=0.0, slip_angle=0.0, time_step=0)
    goal = GoalRegion([CustomState(time_step=Interval(100, 180),
                                   position=Rectangle(40.0, LANE * 3, np.array([400.0, 1.5 * LANE])))])
    problems = PlanningProblemSet([PlanningProblem(1, start, goal)])
    path = folder / "recorded_like_highway.xml"
    write_xml(scenario, problems, path)
    return path


def measure(name: str, xml: Path, backend: str, folder: Path) -> dict:
    record = execute(RunRequest(xml, backend=backend, validate=False), folder / f"{name}-{backend}")
    history = record.history
    scenario, problems = load_scenario(xml)
    cosim, evaluation, planner_vehicle = CosimSettings(), EvaluationSettings(), load_vehicle("sedan")
    excursions = {a.id: a.max_road_excursion_m for a in record.evaluation.agents}    # measured with the run
    clock = time.perf_counter()
    closed_loop_scores(history, scenario, problems, evaluation.score, cosim.offroad_tolerance, excursions)
    score_s = time.perf_counter() - clock
    clock = time.perf_counter()
    solution = run_solution(history, scenario, vehicle_type_of(planner_vehicle), cost_function_of(xml, evaluation.cost_function))
    costs = solution_costs(solution, scenario, problems)
    cost_s = time.perf_counter() - clock
    cache = SolutionCheckCache(folder / f"cache-{name}-{backend}")
    clock = time.perf_counter()
    checks, _ = checked_solution(solution, scenario, problems, xml, cache)
    check_s = time.perf_counter() - clock
    clock = time.perf_counter()
    _, cached = checked_solution(solution, scenario, problems, xml, cache)
    cached_s = time.perf_counter() - clock
    states = sum(len(p.trajectory.state_list) for p in solution.planning_problem_solutions)
    agent = record.agents[0]
    return {"scenario": name, "world": backend, "outcome": str(agent.history.outcome.value), "states": states,
            "wall_s": history.wall_time_s, "score_s": score_s, "cost_s": cost_s,
            "share": (score_s + cost_s) / history.wall_time_s, "check_s": check_s,
            "ms_per_state": 1000 * check_s / max(states, 1), "cached_s": cached_s if cached else math.nan,
            "score": agent.evaluation.score, "cost": costs[agent.id].total if agent.id in costs else None,
            "A": costs[agent.id].partial.get("A").weighted if agent.id in costs and "A" in costs[agent.id].partial else None,
            "valid": checks[agent.id].valid, "reason": checks[agent.id].reason, "obstacles": len(scenario.obstacles)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--files", nargs="*", type=Path, default=[], help="CommonRoad files with recorded traffic")
    parser.add_argument("--worlds", nargs="*", default=["ideal", "mujoco"])
    parser.add_argument("--json", type=Path, metavar="FILE",
                        help="also write what is printed, with commit, date, machine and load, to this results file")
    args = parser.parse_args()
    results_file = BenchmarkResults(tee=args.json)
    folder = Path(tempfile.mkdtemp(prefix="simgap-scoring-"))
    clock = time.perf_counter()
    import commonroad_dc.costs.evaluation  # noqa: F401  (the once-per-process imports, timed apart)
    import scipy.signal  # noqa: F401
    imports_s = time.perf_counter() - clock
    curve = write_scenario(build_scenario("curve", {"radius": 10.0, "angle": 90.0}), folder, preview=False)
    cases = [("paper curve r10 a90", curve), ("recorded-like highway", recorded_like_highway(folder))]
    cases += [(f.stem, f) for f in args.files]
    rows = [measure(name, xml, world, folder) for name, xml in cases for world in args.worlds]
    print(f"once per process: importing commonroad_dc's cost module and scipy.signal took {imports_s:.2f} s\n")
    print(f"{'scenario':<24} {'world':<7} {'obst':>4} {'states':>6} {'run [s]':>8} {'score [s]':>9} {'cost [s]':>8} "
          f"{'share':>6} {'check [s]':>9} {'ms/state':>8} {'cached [s]':>10} {'score':>6} {'cost':>7} {'A':>6}  verdict")
    for r in rows:
        verdict = "valid" if r["valid"] else f"invalid: {r['reason']}" if r["valid"] is False else "not checked"
        print(f"{r['scenario'][:24]:<24} {r['world']:<7} {r['obstacles']:>4} {r['states']:>6} {r['wall_s']:>8.2f} "
              f"{r['score_s']:>9.3f} {r['cost_s']:>8.3f} {100 * r['share']:>5.1f}% {r['check_s']:>9.2f} "
              f"{r['ms_per_state']:>8.1f} {r['cached_s']:>10.4f} {r['score']:>6.3f} "
              f"{'-' if r['cost'] is None else format(r['cost'], '.0f'):>7} "
              f"{'-' if r['A'] is None else format(r['A'], '.0f'):>6}  {verdict} ({r['outcome']})")
    if args.json:
        results_file.write(args.json, {"arguments": vars(args),
                                       "rows": rows})


if __name__ == "__main__":
    main()
