"""The paper's study, reproduced: `experiments/paper-curves.yaml` (78 curve scenarios; ideal once
and MuJoCo with sedan, suv and city: 312 runs), then the paper's Table I for both fidelities
beside the paper's own numbers, and the speed-up ratios.

Usage: python bench/paper/paper_study.py [--out DIR] [--workers 2] [--executor local]
The experiment resumes if DIR holds part of it (the table then covers all finished runs, and the
wall time only this invocation).
"""

from __future__ import annotations

import argparse
import resource
import time
from pathlib import Path

from simgap.experiment.runner import run_experiment
from simgap.experiment.store import ResultsStore
from simgap.files import BenchmarkResults
from simgap.report.scores import store_score_rows as score_table
from simgap.report.time_budget import budget_lines, store_budget

# MultiDrive's Table I (seconds per run): low fidelity (CommonRoad + Frenetix) and high
# fidelity (BeamNG.tech), 78 scenarios each (high fidelity: per vehicle model).
PAPER = {"low": {"min": 12.0, "max": 19.0, "mean": 14.0}, "high": {"min": 122.0, "max": 207.0, "mean": 182.0}}
PAPER_SEQUENTIAL_H = (78 * 14 + 234 * 182) / 3600


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("paper-study"))
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--executor", default="local")
    parser.add_argument("--spec", default="paper-curves")
    parser.add_argument("--json", type=Path, metavar="FILE",
                        help="also write what is printed, with commit, date, machine and load, to this results file")
    parser.add_argument("--against", type=Path, metavar="DIR",
                        help="another finished study (e.g. before a change): compare every run's fingerprint, "
                             "outcome and validity verdict with it, and list each that differs")
    args = parser.parse_args()
    results_file = BenchmarkResults(tee=args.json)
    start = time.perf_counter()
    result = run_experiment(args.spec, args.out, args.workers, args.executor, validate=True)
    wall = time.perf_counter() - start
    print(f"{result.total} runs ({result.ran} now, {result.skipped} earlier, {result.failed} failed) with "
          f"{args.workers} {args.executor} workers: {wall:.1f} s wall including the report "
          f"(runs {result.wall_time_s:.1f} s); the paper's sequential equivalent: {PAPER_SEQUENTIAL_H:.1f} h")
    columns, rows = ResultsStore(args.out).query(
        "SELECT CASE WHEN backend = 'ideal' THEN 'low' ELSE 'high' END AS fidelity, count(*), min(wall_time_s), "
        "max(wall_time_s), avg(wall_time_s), median(wall_time_s), stddev_samp(wall_time_s), "
        "avg(time_planning_s), avg(coalesce(time_physics_s, 0)), avg(coalesce(time_control_s, 0)), "
        "sum(CASE WHEN outcome = 'goal_reached' THEN 1 ELSE 0 END) "
        "FROM runs WHERE status = 'ok' GROUP BY 1 ORDER BY 1 DESC")
    print("\nTable I: wall time per run [s] (simgap; the paper's in brackets)")
    print(f"{'fidelity':<9} {'runs':>5} {'min':>12} {'max':>12} {'mean':>12} {'median':>7} {'std':>6} "
          f"{'planning':>8} {'physics':>8} {'control':>8} {'goals':>6}")
    means = {}
    for fid, n, lo, hi, mean, med, std, plan, phys, ctrl, goals in rows:
        p = PAPER[fid]
        means[fid] = mean
        print(f"{fid:<9} {n:>5} {lo:>5.2f} ({p['min']:>4.0f}) {hi:>5.2f} ({p['max']:>4.0f}) "
              f"{mean:>5.2f} ({p['mean']:>4.0f}) {med:>7.2f} {std:>6.2f} {plan:>8.2f} {phys:>8.2f} {ctrl:>8.2f} "
              f"{goals:>6}")
    if "low" in means and "high" in means:
        print(f"\nspeed-up per run: low fidelity {PAPER['low']['mean'] / means['low']:.1f}x, "
              f"high fidelity {PAPER['high']['mean'] / means['high']:.1f}x; high/low cost ratio "
              f"{means['high'] / means['low']:.2f} (paper {PAPER['high']['mean'] / PAPER['low']['mean']:.1f})")
        print(f"whole study: {PAPER_SEQUENTIAL_H * 3600 / wall:.0f}x faster than the paper's sequential runs")
    print_scores(ResultsStore(args.out))
    print(f"\nWhere the time went (seconds of worker time; bench/paper/study_budget.py {args.out} --sample N breaks "
          f"planning down further)")
    print("\n".join(budget_lines(store_budget(args.out), result.wall_time_s, args.workers)))
    if args.against:
        print_differences(ResultsStore(args.against), ResultsStore(args.out))
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    print(f"peak resident memory of the largest worker: {usage.ru_maxrss / 1024:.0f} MB; "
          f"of this process: {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB")
    if args.json:
        results_file.write(args.json, {"arguments": vars(args)})


def print_differences(before: ResultsStore, after: ResultsStore) -> None:
    """Run by run (by key), what differs between two studies: fingerprint, outcome, validity."""
    fields = ("fingerprint", "outcome", "solution_valid", "solution_reason")
    query = f"SELECT key, {', '.join(fields)} FROM runs WHERE status = 'ok'"
    old = {r[0]: r[1:] for r in before.query(query)[1]}
    new = {r[0]: r[1:] for r in after.query(query)[1]}
    both = sorted(old.keys() & new.keys())
    print(f"\nAgainst {before.root}: {len(both)} runs in both ({len(old) - len(both)} only there, "
          f"{len(new) - len(both)} only here)")
    for i, name in enumerate(fields):
        differ = [k for k in both if old[k][i] != new[k][i]]
        print(f"  {name}: {len(both) - len(differ)} equal, {len(differ)} differ"
              + "".join(f"\n    {k}: {old[k][i]} -> {new[k][i]}" for k in differ[:20]))


def print_scores(store: ResultsStore) -> None:
    """Per car: the closed-loop score in the ideal world and in MuJoCo, the drop and the component
    that explains most of it (its mean share of the drop), the CommonRoad cost, and how many
    solutions valid in the ideal world are invalid on the car, and why; the scoring phases' times."""
    rows = score_table(store.run_rows())
    print("\nScores (closed-loop score; KS2/SM1 solution cost and validity), MuJoCo against ideal per curve")
    print(f"{'fidelity':<14} {'runs':>4} {'ideal':>6} {'mujoco':>6} {'drop':>6} {'max':>6} {'lost':>4}  "
          f"{'cost ideal':>10} {'mujoco':>7} {'valid i/m':>9} {'broke':>5}  lost most on; broke because")
    for r in rows:
        print(f"{r['fidelity']:<14} {r['runs']:>4} {r['ideal score']:>6.3f} {r['score']:>6.3f} {r['mean drop']:>6.3f} "
              f"{r['largest drop']:>6.3f} {r['runs that lost']:>4}  {r['ideal cost']:>10.0f} {r['cost']:>7.0f} "
              f"{r['ideal valid']:>4}/{r['valid']:<4} {r['ideal-valid now invalid']:>5}  {r['lost most on']}; "
              f"{r['because']}")
    columns, phases = store.query("SELECT fidelity, avg(time_scoring_s / wall_time_s), avg(time_scoring_s), "
                                  "avg(time_validation_s), max(time_validation_s) FROM runs WHERE status = 'ok' "
                                  "GROUP BY 1 ORDER BY 1")
    for fid, share, scoring, validation, slowest in phases:
        print(f"  {fid}: scoring {scoring:.3f} s per run ({100 * share:.1f} % of its wall time), "
              f"validation {validation:.2f} s (longest {slowest:.2f} s)")


if __name__ == "__main__":
    main()
