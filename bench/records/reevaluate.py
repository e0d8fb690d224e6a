"""Every run below a folder evaluated again from its history, and compared with the evaluation its
record keeps: for a change to `simgap.evaluate` that must not change a figure (the runs are not
simulated again, so a folder of hundreds of runs takes a minute or two).

    python bench/records/reevaluate.py RUNS [--json F]

The scenario is the file the record names (its recorded egos left out, as the run did), the road's
friction the backend's setting, the planner's vehicle and the loop's settings the record's. The
criticality of agent pairs is compared where the record has it. Prints per field how many agents
are equal, the first differences, and the time `evaluate` took per run.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from simgap.evaluate.run_evaluation import EvaluationContext, evaluate, with_criticality
from simgap.files import BenchmarkResults
from simgap.record import read_run
from simgap.record.values import plain, same
from simgap.scenario import load_scenario
from simgap.scenario.ground import ground_of_file
from simgap.scenario.obstacles import without_recorded_egos
from simgap.scenario.relief import road_tilt
from simgap.sim.settings import road_friction
from simgap.vehicles import load_vehicle

FIELDS = ("time_to_goal_s", "distance_m", "min_distance_to_traffic_m", "max_road_excursion_m", "planning_calls",
          "planning_mean_s", "planning_over_budget", "plan_latency_mean_s", "tracking", "score",
          "score_components", "score_measures", "solution_benchmark", "solution_cost", "solution_partial_costs",
          "solution_cost_error")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", type=Path)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    results_file = BenchmarkResults(argv)
    equal, differ, examples, seconds, runs = {}, {}, [], 0.0, 0
    for run_json in sorted(args.runs.rglob("run.json")):
        record = read_run(run_json.parent)
        xml = Path(record.settings.scenario_path)
        scenario, problems = load_scenario(xml)
        scenario, _ = without_recorded_egos(scenario, problems)
        context = EvaluationContext(scenario, problems, record.settings.evaluation, record.settings.cosim.offroad_tolerance,
                                    record.settings.cosim.planning_budget_s,
                                    road_friction(record.settings.backend),
                                    load_vehicle(record.settings.planner_vehicle or "sedan"),
                                    ground_of_file(xml, scenario.lanelet_network, road_tilt(record.settings.backend)),
                                    xml)
        clock = time.perf_counter()
        again = evaluate(record.history, context)
        seconds += time.perf_counter() - clock
        runs += 1
        if record.evaluation.criticality:
            again = with_criticality(again, record.history, context)
        checks = [("metrics", dict(record.evaluation.metrics), dict(again.metrics)),
                  ("criticality", plain(dict(enumerate(record.evaluation.criticality))),
                   plain(dict(enumerate(again.criticality))) if record.evaluation.criticality else
                   plain(dict(enumerate(record.evaluation.criticality))))]
        for was, now in zip(record.evaluation.agents, again.agents, strict=True):
            checks += [(name, plain(getattr(was, name)), plain(getattr(now, name))) for name in FIELDS
                       if not (name == "tracking" and was.tracking is None)]
        for name, a, b in checks:
            ok = same(a, b)
            (equal if ok else differ)[name] = (equal if ok else differ).get(name, 0) + 1
            if not ok and len(examples) < 10:
                examples.append({"run": str(run_json.parent.relative_to(args.runs)), "what": name, "recorded": a,
                                 "again": b})
    print(f"{runs} runs evaluated again: {1000 * seconds / max(runs, 1):.1f} ms per run in evaluate")
    for name in sorted(set(equal) | set(differ)):
        print(f"  {name:<28} equal {equal.get(name, 0):>5}   differ {differ.get(name, 0):>5}")
    for example in examples:
        print("  differs:", json.dumps(example, default=str)[:400])
    if args.json:
        results_file.write(args.json, {"runs": runs, "evaluate_ms_per_run": 1000 * seconds / max(runs, 1),
                                        "equal": equal, "differ": differ,
                                        "examples": json.loads(json.dumps(examples, default=str))})
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
