"""Two finished studies (experiments) of the same spec, run by run and agent by agent: is every
outcome, metric and score the same? For a change that must not change behaviour (a refactor):
the runs of BEFORE (any run-record format; older ones read through `simgap.record.migrate`) and
AFTER are matched by their store key (folders of run directories without a store, as
`run_corpus.py` writes them: by their path), and compared

- row by row: every column of the results store but those that measure the machine (wall and
  phase times, the planner's call times, versions, where the run was written);
- from the run records: the fingerprint (every driven state, bit for bit), the failure, every event
  (time, place, kind, detail); agent by agent the outcome, the time to the goal, the distance, the
  closest approach, the road excursion, the plan latencies, the score with its components and
  measures, the solution's cost with its terms, validity and reason; the run's metrics; and the
  criticality of its agent pairs where both have it (a study of format 1 has it where its report
  cached it).

Floats are equal when equal to 1e-9 (relative) or both NaN. Prints the counts per column and
the first differences; ``--json F`` writes them.

    python bench/records/compare_studies.py BEFORE AFTER [--json F]

Besides the counts it prints the planning calls' mean wall time before and after (a hot path:
the planning cycle), over the runs of both.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import Counter
from pathlib import Path
from typing import Any

from simgap.experiment.store import ResultsStore
from simgap.files import BenchmarkResults
from simgap.record import read_run
from simgap.record.values import plain, same

MACHINE = ("time_", "version_", "job_time_s", "wall_time_s", "planning_mean_s", "planning_p95_s", "planning_max_s",
           "run_dir", "reproduce", "format_version")     # reproduce: the command names the run's directory
HISTORY_FIELDS = ("outcome", "time_to_goal_s", "planner_failures", "planner_exceptions")    # the rest: evaluation's
AGENT_FIELDS = ("outcome", "time_to_goal_s", "distance_m", "min_distance_to_traffic_m", "max_road_excursion_m",
                "planner_failures", "planner_exceptions", "planning_calls", "plan_latency_mean_s",
                "plan_latency_max_s", "score", "score_components", "score_measures", "solution_benchmark",
                "solution_cost", "solution_partial_costs", "solution_cost_error", "solution_valid", "solution_reason")


def _rows(root: Path) -> dict[str, dict[str, Any]]:
    """The store's rows by key; a folder of run directories without a store (`run_corpus.py`):
    one empty row per run directory, keyed by its path."""
    if (root / "store").is_dir():
        return {r["key"]: r for r in ResultsStore(root).rows()}
    return {str(p.parent.relative_to(root)): {"run_dir": str(p.parent.relative_to(root))}
            for p in sorted(root.rglob("run.json"))}


def compare(before: Path, after: Path) -> dict[str, Any]:
    rows_a, rows_b = _rows(before), _rows(after)
    keys = sorted(set(rows_a) & set(rows_b))
    equal, differ, examples = Counter(), Counter(), []
    planning = {"before": [0, 0.0], "after": [0, 0.0]}          # calls, seconds
    for key in keys:
        a, b = rows_a[key], rows_b[key]
        for column in sorted((set(a) | set(b)) - {"run_dir"}):
            if column.startswith(MACHINE) or column in MACHINE:
                continue
            if column not in a or column not in b:
                differ[f"row.{column} (only in {'after' if column in b else 'before'})"] += 1
                continue
            ok = same(a[column], b[column])
            (equal if ok else differ)[f"row.{column}"] += 1
            if not ok and len(examples) < 20:
                examples.append({"key": key, "what": f"row.{column}", "before": a[column], "after": b[column]})
        if not (a.get("run_dir") and b.get("run_dir")):
            continue
        ra, rb = read_run(before / a["run_dir"]), read_run(after / b["run_dir"])
        for what, va, vb in (("fingerprint", ra.fingerprint, rb.fingerprint), ("failure", ra.failure, rb.failure),
                             ("events", [plain(e) for e in ra.history.events], [plain(e) for e in rb.history.events])):
            ok = va == vb
            (equal if ok else differ)[what] += 1
            if not ok and len(examples) < 20:
                examples.append({"key": key, "what": what, "before": va, "after": vb})
        for name in sorted(set(ra.evaluation.metrics) | set(rb.evaluation.metrics)):
            va, vb = ra.evaluation.metrics.get(name), rb.evaluation.metrics.get(name)
            ok = va is not None and vb is not None and same(float(va), float(vb))
            (equal if ok else differ)[f"metrics.{name}"] += 1
        if ra.evaluation.criticality and rb.evaluation.criticality:     # (a run of format 1: as its report cached it)
            ok = same(plain({i: c for i, c in enumerate(ra.evaluation.criticality)}),
                      plain({i: c for i, c in enumerate(rb.evaluation.criticality)}))
            (equal if ok else differ)["criticality"] += 1
            if not ok and len(examples) < 20:
                examples.append({"key": key, "what": "criticality", "before": plain(list(ra.evaluation.criticality)),
                                 "after": plain(list(rb.evaluation.criticality))})
        for agent_a, agent_b in zip(ra.agents, rb.agents, strict=True):
            for side, agent in (("before", agent_a), ("after", agent_b)):
                calls, mean_s = agent.evaluation.planning_calls, agent.evaluation.planning_mean_s
                if calls and mean_s is not None:
                    planning[side][0] += calls
                    planning[side][1] += calls * mean_s
            for name in AGENT_FIELDS:
                part_a, part_b = (agent_a.history, agent_b.history) if name in HISTORY_FIELDS else \
                    (agent_a.evaluation, agent_b.evaluation)
                va, vb = plain(getattr(part_a, name)), plain(getattr(part_b, name))
                ok = same(va, vb)
                (equal if ok else differ)[f"agent.{name}"] += 1
                if not ok and len(examples) < 20:
                    examples.append({"key": key, "agent": agent_a.id, "what": f"agent.{name}", "before": va,
                                     "after": vb})
    return {"before": str(before), "after": str(after), "runs": len(keys),
            "only_before": sorted(set(rows_a) - set(rows_b)), "only_after": sorted(set(rows_b) - set(rows_a)),
            "equal": dict(sorted(equal.items())), "differ": dict(sorted(differ.items())), "examples": examples,
            "planning_call_mean_ms": {side: 1000 * t / n if n else None for side, (n, t) in planning.items()},
            "planning_calls": {side: n for side, (n, _) in planning.items()}}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("before", type=Path)
    parser.add_argument("after", type=Path)
    parser.add_argument("--json", type=Path, help="write the comparison here")
    args = parser.parse_args(argv)
    results_file = BenchmarkResults(argv)
    result = compare(args.before, args.after)
    print(f"{result['runs']} runs in both; only before {len(result['only_before'])}, only after "
          f"{len(result['only_after'])}")
    for what in sorted(set(result["equal"]) | set(result["differ"])):
        print(f"  {what:<45} equal {result['equal'].get(what, 0):>5}   differ {result['differ'].get(what, 0):>5}")
    ms = result["planning_call_mean_ms"]
    if ms["before"] and ms["after"]:
        print(f"  planning call: {ms['before']:.2f} ms before, {ms['after']:.2f} ms after (mean over "
              f"{result['planning_calls']['before']} and {result['planning_calls']['after']} calls)")
    for example in result["examples"]:
        print("  differs:", json.dumps(example, default=str))
    if args.json:
        results_file.write(args.json, json.loads(json.dumps(result, default=str)))
    return 1 if result["differ"] or result["only_before"] or result["only_after"] else 0


if __name__ == "__main__":
    sys.exit(main())
