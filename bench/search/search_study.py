"""Multi-fidelity search against the baselines, at equal wall-clock budget: the built-in
`curve-gaps` search (the curve road under friction, actuator delays, localisation drift, bank and
grade; ideal → single-track screen → MuJoCo) with each strategy on the same budget and workers,
repeated over seeds (the spec's ``seed``: each strategy's own random choices).

Prints, per seed and strategy: runs per rung, high-fidelity failures, violated assumptions (pass
ideal, fail MuJoCo), distinct ones after de-duplication, CPU hours, distinct failures per CPU hour,
the ratio to grid search, the distinct scenarios (road, start, vehicle) among the violations, the
failure modes (with ``--follow-up``: each strategy's violations probed, confirmed and explained
within its budget as `simgap search` does, `simgap.experiment.search.follow_up`; without, the
strategies search on their whole shares and report no modes),
the share of ideal passes that fail in MuJoCo; then per strategy the mean and the spread
(standard deviation, and min–max) over the seeds of distinct violations, distinct failing
scenarios and failure modes, with the means' ratios to grid; then the per-phase timings of a run
in each rung (runs whose ideal verdict was copied from another candidate's run are not counted).

Usage: python bench/search/search_study.py [--budget 20m] [--workers 2] [--seeds 3] [--follow-up]
       [--out DIR] [--strategy NAME ...]
Each seed searches in DIR/seed-N; re-running on the same DIR resumes (a larger --budget goes on).
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import yaml

from simgap.experiment.search import Budget, parse_budget, run_search
from simgap.experiment.search.follow_up import FollowUp
from simgap.experiment.search.results import StrategyResult
from simgap.experiment.search.spec import load_search_spec
from simgap.experiment.store import ResultsStore
from simgap.files import BenchmarkResults

PHASES = ("job_time_s", "wall_time_s", "time_planning_s", "time_control_s", "time_physics_s", "time_monitoring_s")
FOUND = (("distinct violations", lambda r: r.distinct), ("failing scenarios", lambda r: r.scenarios),
         ("failure modes", lambda r: len(r.modes)))


def _total(per_strategy: Budget, strategies: list[str]) -> Budget:
    """The search's budget that gives each of ``strategies`` ``per_strategy`` (`simgap search`
    shares its budget evenly among them)."""
    n = len(strategies)
    return Budget(seconds=per_strategy.seconds * n) if per_strategy.seconds is not None \
        else Budget(runs=(per_strategy.runs or 0) * n)


def seeded_spec(spec: str, seed: int, folder: Path) -> Path:
    """The spec ``spec`` (a file or a built-in name) with its ``seed`` set, written in ``folder``."""
    search = load_search_spec(spec)
    data = yaml.safe_load(search.file.read_text()) | {"seed": seed}
    if not search.logical.name == data["logical"]:           # a logical scenario file: relative to the spec
        data["logical"] = str((search.file.parent / data["logical"]).resolve())
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "spec.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def print_seed(out: Path, results: list[StrategyResult]) -> None:
    grid = next((r for r in results if r.name == "grid"), None)
    head = (f"{'strategy':15s} {'wall min':>8s} {'runs':>5s} {'ideal':>5s} {'screen':>6s} {'high':>5s} "
            f"{'high fail':>9s} {'violations':>10s} {'distinct':>8s} {'scenarios':>9s} {'modes':>5s} {'CPU h':>6s} "
            f"{'per CPU h':>9s} {'x grid':>6s} {'ideal pass→fail':>15s}")
    print(head)
    print("-" * len(head))
    for r in results:
        rows = ResultsStore(out / r.name).rows()
        per_rung = [sum(1 for x in rows if int(x["rung"]) == k and "ideal_of" not in x) for k in range(3)]
        high = [x for x in rows if int(x["rung"]) == 2 and x["status"] == "ok"]
        ideal_failed = {int(x["candidate"]) for x in rows if int(x["rung"]) == 0 and x.get("failed")}
        passes = len([x for x in high if int(x["candidate"]) not in ideal_failed])
        share = 100.0 * r.violations / passes if passes else float("nan")
        ratio = r.distinct / grid.distinct if grid and grid.distinct else float("nan")
        print(f"{r.name:15s} {r.wall_s / 60:8.1f} {r.runs:5d} {per_rung[0]:5d} {per_rung[1]:6d} {per_rung[2]:5d} "
              f"{r.high_failures:9d} {r.violations:10d} {r.distinct:8d} {r.scenarios:9d} {len(r.modes):5d} "
              f"{r.cpu_s / 3600:6.2f} {r.per_cpu_hour:9.1f} {ratio:6.2f} {share:14.1f}%")


def print_spread(per_seed: list[list[StrategyResult]]) -> None:
    """Per strategy, the mean, standard deviation and range over the seeds, and the means' ratio to grid's."""
    names = [r.name for r in per_seed[0]]
    means = {(n, what): statistics.mean(get(r) for rs in per_seed for r in rs if r.name == n)
             for n in names for what, get in FOUND}
    head = f"{'strategy':15s} " + " ".join(f"{what + ' (mean ± sd, min–max, x grid)':>46s}" for what, _ in FOUND)
    print(head)
    print("-" * len(head))
    for n in names:
        cells = []
        for what, get in FOUND:
            xs = [get(r) for rs in per_seed for r in rs if r.name == n]
            sd = statistics.stdev(xs) if len(xs) > 1 else 0.0
            grid = means.get(("grid", what))
            ratio = f"{means[(n, what)] / grid:.2f}" if grid else "-"
            cells.append(f"{means[(n, what)]:.1f} ± {sd:.1f}, {min(xs)}–{max(xs)}, x{ratio}")
        print(f"{n:15s} " + " ".join(f"{c:>46s}" for c in cells))


def print_phases(dirs: list[Path], per_seed: list[list[StrategyResult]]) -> None:
    print("\nmedian seconds per run, by rung (all strategies and seeds)")
    rows = [x for out, results in zip(dirs, per_seed) for r in results for x in ResultsStore(out / r.name).rows()
            if x["status"] == "ok" and "ideal_of" not in x]
    print(f"{'rung':8s} {'runs':>5s} " + " ".join(f"{p.removeprefix('time_').removesuffix('_s'):>10s}" for p in PHASES))
    for k, label in enumerate(("ideal", "screen", "high")):
        sel = [x for x in rows if int(x["rung"]) == k]
        if not sel:
            continue
        meds = [statistics.median(float(x.get(p) or 0.0) for x in sel) for p in PHASES]
        print(f"{label:8s} {len(sel):5d} " + " ".join(f"{m:10.2f}" for m in meds))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spec", default="curve-gaps")
    parser.add_argument("--budget", default="20m")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seeds", type=int, default=1, help="repeat the study with spec seeds 0..N-1")
    parser.add_argument("--follow-up", action="store_true",
                        help="follow up each strategy's violations within its budget, as simgap search does (probes, "
                             "confirmation, explanation); off: each strategy searches on its whole share")
    parser.add_argument("--out", type=Path, default=Path("search-study"))
    parser.add_argument("--strategy", action="append", default=None)
    parser.add_argument("--json", type=Path, metavar="FILE",
                        help="also write what is printed, with commit, date, machine and load, to this results file")
    args = parser.parse_args()
    results_file = BenchmarkResults(tee=args.json)
    start = time.perf_counter()
    dirs, per_seed = [], []
    for seed in range(args.seeds):
        out = args.out / f"seed-{seed}"
        spec = seeded_spec(args.spec, seed, args.out / "specs" / f"seed-{seed}")
        results = run_search(spec, out, _total(parse_budget(args.budget), args.strategy or
                                               list(load_search_spec(spec).spec.strategies)),
                             args.workers, strategies=args.strategy,
                             follow_up=FollowUp() if args.follow_up else None)
        print(f"\nseed {seed}: budget {args.budget} per strategy, {args.workers} workers, "
              f"{'with' if args.follow_up else 'no'} follow-up; "
              f"{time.perf_counter() - start:.0f} s so far\n")
        print_seed(out, results)
        dirs.append(out)
        per_seed.append(results)
    print(f"\nover {args.seeds} seed{'s' if args.seeds > 1 else ''}:")
    print_spread(per_seed)
    print_phases(dirs, per_seed)
    if args.json:
        results_file.write(args.json, {"arguments": vars(args)})


if __name__ == "__main__":
    main()
