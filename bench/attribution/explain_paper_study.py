"""Why the paper study's physical runs part from the ideal ones: `simgap explain` on each MuJoCo
run that fails or parts from its ideal run by more than 0.1 m, per car — the dominant assumption
per curve, whether restoring it alone fixes the outcome, the wall time of each explanation
against the run's own, and where the shares did not add up to the gap measured against the
study's own ideal run (more than 5 % apart).

The cost of an explanation is its wall time (`simgap.experiment.attribution.explain`, on
``--workers`` processes) over the run's own wall time as its record keeps it (the co-simulation
loop, `History.wall_time_s`: not the planner's set-up, the evaluation or the files). The fork
server the workers come from is started once, before the first run (as `simgap run --explain` and
an experiment's ``explain:`` start it), not in each explanation's time. Beside it the processor
time of both (the explanation's: this process's, the worlds it made among it, and each world's a
worker made; the run's: this process's while it ran, set-up and evaluation included), which a
machine's load changes less than the wall time.

Either reads a finished study (`bench/paper/paper_study.py --out DIR`, or `simgap experiment run
experiments/paper-curves.yaml --out DIR`; its scenario files where they were run; no processor
times), or runs the curves itself, each MuJoCo run just before its explanation, as the study runs
them (its spec's loop settings; the ideal world once per curve, with the study's vehicle): the
study's whole grid (``--grid``, in the order of ``--angles`` first, then the grid's other angles)
or the ``--curves`` given. ``--until HH:MM`` (UTC) starts no curve after then; the results file
says which curves were run.

Usage: MUJOCO_GL=egl python bench/attribution/explain_paper_study.py (--study DIR | --grid | --curves 10,90 20,-90 ...)
       [--angles 90 -90] [--until 15:40] [--vehicles sedan suv city] [--threshold 0.1] [--limit N] [--workers 2]
       [--json FILE]
No pass/fail.
"""

from __future__ import annotations

import argparse
import datetime as dt
import statistics
import tempfile
import time
from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from simgap.cosim import Outcome
from simgap.evaluate.compare import compare_histories
from simgap.experiment import fork_server
from simgap.experiment.attribution import explain
from simgap.experiment.samplers import sample
from simgap.experiment.single_run import RunRequest, execute
from simgap.experiment.spec import load_spec
from simgap.files import BenchmarkResults
from simgap.report.collection import collect
from simgap.scenario import build_scenario, load_scenario, write_scenario
from simgap.sim.mujoco.plant import compile_tyres
from simgap.vehicles import vehicle_names

ADDS_UP = 0.05       # the shares' sum within 5 % of the gap measured against the study's ideal run
SPEC = "paper-curves"


def study_runs(study: Path, vehicles: list[str]) -> Iterator[dict[str, Any]]:
    """Each physical run of a finished study: curve, vehicle, run directory, outcome, gap against
    the study's ideal run."""
    for group in collect(study / "runs"):
        curve = f"r={group.parameters.get('radius'):g} {group.parameters.get('angle'):g}°"
        for fidelity, comparisons in group.comparisons.items():
            entry = group.runs[fidelity]
            vehicle = entry.run.agents[0].history.vehicle.name
            if vehicle in vehicles:
                yield {"curve": curve, "vehicle": vehicle, "run_dir": entry.run_dir,
                       "outcome": str(entry.run.agents[0].history.outcome),
                       "gap_m": max((c.lateral_displacement.max for c in comparisons), default=0.0), "run_cpu_s": None}


def grid(angles_first: list[float]) -> list[dict[str, Any]]:
    """The paper study's curves (its spec's grid), those at ``angles_first`` first (each angle's
    radii in order), then the others in the grid's order."""
    experiment = load_spec(SPEC)
    points = sample(experiment.spec, experiment.logical)
    rank = {a: i for i, a in enumerate(angles_first)}
    return sorted(points, key=lambda p: rank.get(p["angle"], len(rank)))      # (stable: by radius within an angle)


def own_runs(curves: list[dict[str, Any]], vehicles: list[str], folder: Path, until: dt.datetime | None,
             ran: list[str]) -> Iterator[dict[str, Any]]:
    """The same, for ``curves`` run here as the study runs them (its loop settings, MuJoCo against
    the ideal world run once with the study's vehicle); each curve started is added to ``ran``."""
    experiment = load_spec(SPEC)
    cosim = experiment.cosim
    settings = {v.vehicle: v.settings for variants in experiment.variants for v in variants
                if v.fidelity.backend == "mujoco"}
    for parameters in curves:
        if until is not None and dt.datetime.now(dt.UTC) >= until:
            return
        curve = f"r={parameters['radius']:g} {parameters['angle']:g}°"
        ran.append(curve)
        xml = write_scenario(build_scenario("curve", parameters), folder, preview=False)
        scenario, problems = load_scenario(xml)
        ideal = execute(RunRequest(scenario=xml, cosim=cosim, planner_vehicle=experiment.planner_vehicle,
                                   criticality=False))
        for vehicle in vehicles:
            run_dir = folder / f"{xml.stem}-{vehicle}"
            cpu = time.process_time()
            hifi = execute(RunRequest(scenario=xml, backend="mujoco", vehicles=vehicle, cosim=cosim,
                                      backend_settings=settings[vehicle], planner_vehicle=experiment.planner_vehicle,
                                      criticality=False), run_dir)
            cpu = time.process_time() - cpu
            gap = max((c.lateral_displacement.max for c in compare_histories(ideal.history, hifi.history, scenario,
                                                                              problems)), default=0.0)
            yield {"curve": curve, "vehicle": vehicle, "run_dir": run_dir, "outcome": str(hifi.agents[0].history.outcome),
                   "gap_m": gap, "run_cpu_s": cpu}


def summary(rows: list[dict[str, Any]], considered: int, vehicles: list[str]) -> dict[str, Any]:
    """The counts the docs show: runs considered and explained, how many add up within 5 %, the
    dominant assumption's counts per car, and the cost ratios."""
    ratios = [r["cost_ratio"] for r in rows]
    cpu = [r["cpu_ratio"] for r in rows if r.get("cpu_ratio") is not None]
    return {"physical_runs": considered, "explained": len(rows), "adds_up": sum(r["adds_up"] for r in rows),
            "fixes_outcome": sum(bool(r["fixes_outcome"]) for r in rows if r["outcome"] != "goal_reached"),
            "failed": sum(r["outcome"] != "goal_reached" for r in rows),
            "dominant": {v: dict(Counter(r["dominant"] for r in rows if r["vehicle"] == v).most_common())
                         for v in vehicles},
            "explained_per_car": {v: sum(r["vehicle"] == v for r in rows) for v in vehicles},
            "cost_ratio": {"median": statistics.median(ratios) if ratios else None, "max": max(ratios, default=None),
                           "over_8": sum(x > 8 for x in ratios)},
            "cpu_ratio": {"median": statistics.median(cpu) if cpu else None, "max": max(cpu, default=None)}}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--study", type=Path, help="a finished paper study's directory")
    source.add_argument("--grid", action="store_true", help="run the paper study's whole grid of curves here")
    source.add_argument("--curves", nargs="+", help="RADIUS,ANGLE: run these curves here")
    parser.add_argument("--angles", nargs="+", type=float, default=[90.0, -90.0],
                        help="with --grid: the curves of these angles first [deg]")
    parser.add_argument("--until", help="with --grid or --curves: start no curve after this time, HH:MM UTC")
    parser.add_argument("--vehicles", nargs="+", default=vehicle_names())
    parser.add_argument("--threshold", type=float, default=0.1, help="explain runs that part by more [m]")
    parser.add_argument("--limit", type=int, help="explain at most this many runs")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--json", type=Path, metavar="FILE",
                        help="also write the rows, with commit, date, machine and load, to this results file")
    args = parser.parse_args()
    results_file = BenchmarkResults(tee=args.json)
    until = None
    if args.until:
        hour, minute = (int(x) for x in args.until.split(":"))
        until = dt.datetime.now(dt.UTC).replace(hour=hour, minute=minute, second=0, microsecond=0)
    if args.grid:
        curves = grid(args.angles)
    elif args.curves:
        curves = [{"radius": float(r), "angle": float(a)} for r, a in (spec.split(",") for spec in args.curves)]
    rows: list[dict[str, Any]] = []
    ran: list[str] = []
    considered = 0
    if args.workers > 1:      # loading what a run imports, once, while the first runs run (as simgap run --explain)
        fork_server.start()
    compile_tyres()           # the tyre kernel loaded here before the first run, not inside its timed loop
    with tempfile.TemporaryDirectory() as tmp:
        runs = study_runs(args.study, args.vehicles) if args.study else \
            own_runs(curves, args.vehicles, Path(tmp), until, ran)
        print(f"{'curve':<12} {'vehicle':<7} {'outcome':<13} {'gap [m]':>7} {'dominant':<16} {'fixes':<5} "
              f"{'sum/gap':>7} {'runs':>4} {'wall [s]':>8} {'run [s]':>7} {'ratio':>5} {'cpu':>5}  shares [m]")
        for run in runs:
            considered += 1
            if run["outcome"] == Outcome.GOAL_REACHED and run["gap_m"] <= args.threshold:
                continue
            if args.limit is not None and len(rows) >= args.limit:
                break
            x = explain(run["run_dir"], args.workers)
            cpu = x.cpu_s
            top, gap = x.assumptions[0], run["gap_m"]
            total = sum(a.share_m for a in x.assumptions)
            ratio = total / gap if gap > 0 else float("nan")
            row = {"curve": run["curve"], "vehicle": run["vehicle"], "outcome": run["outcome"], "gap_m": gap,
                   "dominant": str(top.name), "fixes_outcome": top.fixes_outcome, "sum_over_gap": ratio,
                   "adds_up": abs(ratio - 1.0) <= ADDS_UP, "runs": x.runs, "wall_s": x.wall_s,
                   "run_wall_s": x.run_wall_s, "cost_ratio": x.wall_s / x.run_wall_s,
                   "cpu_s": cpu, "run_cpu_s": run["run_cpu_s"],
                   "cpu_ratio": None if run["run_cpu_s"] is None else cpu / run["run_cpu_s"],
                   "explanation": x.as_json(), "sentence": x.sentence()}
            rows.append(row)
            shares = " ".join(f"{a.name}={a.share_m:.3f}" for a in x.assumptions)
            cpu_ratio = "—" if row["cpu_ratio"] is None else f"{row['cpu_ratio']:.1f}"
            print(f"{run['curve']:<12} {run['vehicle']:<7} {run['outcome']:<13} {gap:>7.3f} {top.name:<16} "
                  f"{str(top.fixes_outcome):<5} {ratio:>7.3f} {x.runs:>4} {x.wall_s:>8.1f} {x.run_wall_s:>7.2f} "
                  f"{row['cost_ratio']:>5.1f} {cpu_ratio:>5}  {shares}", flush=True)
    counts = summary(rows, considered, args.vehicles)
    print(f"{considered} physical runs, {len(rows)} explained (failed or parted by more than {args.threshold} m), "
          f"{counts['adds_up']} adding up within 5 %")
    for vehicle in args.vehicles:
        if counts["dominant"][vehicle]:
            print(f"{vehicle}: dominant " + ", ".join(f"{k} {n}" for k, n in counts["dominant"][vehicle].items()) +
                  f" ({counts['explained_per_car'][vehicle]} runs explained)")
    if rows:
        cost = counts["cost_ratio"]
        print(f"explanation wall time / run wall time: median {cost['median']:.1f}, largest {cost['max']:.1f}, "
              f"{cost['over_8']} over 8 (on {args.workers} workers)")
        off = [f"{r['curve']} {r['vehicle']} ({r['sum_over_gap']:.3f})" for r in rows if not r["adds_up"]]
        print("shares not adding up to the study's gap within 5 %: " + (", ".join(off) or "none"))
    if args.json:
        arguments = {k: str(v) for k, v in vars(args).items()}
        results_file.write(args.json, {"arguments": arguments, "curves_run": ran if not args.study else None,
                                       "curves_in_grid": len(grid(args.angles)), "summary": counts, "rows": rows})


if __name__ == "__main__":
    main()
