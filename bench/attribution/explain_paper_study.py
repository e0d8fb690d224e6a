"""Why the paper study's physical runs part from the ideal ones: `simgap explain` on each MuJoCo
run that fails or parts from its ideal run by more than 0.1 m, per car — the dominant assumption
per curve, whether restoring it alone fixes the outcome, the wall time of each explanation
against the run's own, and where the shares did not add up to the gap measured against the
study's own ideal run (more than 5 % apart).

Either reads a finished study (`bench/paper/paper_study.py --out DIR`, or `simgap experiment run
experiments/paper-curves.yaml --out DIR`; its scenario files where they were run), or runs the
curves given itself (`--curves`: the paper's cosim, replanning every step, seed 0).

Usage: MUJOCO_GL=egl python bench/attribution/explain_paper_study.py (--study DIR | --curves 10,90 20,-90 ...)
       [--vehicles sedan suv city] [--threshold 0.1] [--limit N] [--workers 2] [--json FILE]
No pass/fail.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
from collections import Counter
from pathlib import Path
from typing import Iterator

from simgap.cosim import CosimSettings, Outcome
from simgap.evaluate.compare import compare_histories
from simgap.experiment.attribution import explain
from simgap.experiment.single_run import RunRequest, execute
from simgap.files import BenchmarkResults
from simgap.report.collection import collect
from simgap.scenario import build_scenario, load_scenario, write_scenario
from simgap.vehicles import vehicle_names

ADDS_UP = 0.05       # the shares' sum within 5 % of the gap measured against the study's ideal run


def study_runs(study: Path, vehicles: list[str]) -> Iterator[tuple[str, str, Path, str, float]]:
    """(curve, vehicle, run directory, outcome, gap against the study's ideal run) of each physical run."""
    for group in collect(study / "runs"):
        curve = f"r={group.parameters.get('radius')} {group.parameters.get('angle')}°"
        for fidelity, comparisons in group.comparisons.items():
            entry = group.runs[fidelity]
            vehicle = entry.run.agents[0].history.vehicle.name
            if vehicle in vehicles:
                yield (curve, vehicle, entry.run_dir, str(entry.run.agents[0].history.outcome),
                       max((c.lateral_displacement.max for c in comparisons), default=0.0))


def own_runs(curves: list[str], vehicles: list[str], folder: Path) -> Iterator[tuple[str, str, Path, str, float]]:
    """The same, for the curves run here (MuJoCo against the ideal world, the paper's cosim)."""
    cosim = CosimSettings(replan_every=1)
    for spec in curves:
        radius, angle = (float(x) for x in spec.split(","))
        xml = write_scenario(build_scenario("curve", {"radius": radius, "angle": angle}), folder, preview=False)
        scenario, problems = load_scenario(xml)
        for vehicle in vehicles:
            run_dir = folder / f"{xml.stem}-{vehicle}"
            ideal = execute(RunRequest(scenario=xml, vehicles=vehicle, cosim=cosim, criticality=False))
            hifi = execute(RunRequest(scenario=xml, backend="mujoco", vehicles=vehicle, cosim=cosim,
                                      criticality=False), run_dir)
            gap = max((c.lateral_displacement.max for c in compare_histories(ideal.history, hifi.history, scenario,
                                                                              problems)), default=0.0)
            yield f"r={radius:g} {angle:g}°", vehicle, run_dir, str(hifi.agents[0].history.outcome), gap


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--study", type=Path, help="a finished paper study's directory")
    source.add_argument("--curves", nargs="+", help="RADIUS,ANGLE: run these curves here")
    parser.add_argument("--vehicles", nargs="+", default=vehicle_names())
    parser.add_argument("--threshold", type=float, default=0.1, help="explain runs that part by more [m]")
    parser.add_argument("--limit", type=int, help="explain at most this many runs")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--json", type=Path, metavar="FILE",
                        help="also write the rows, with commit, date, machine and load, to this results file")
    args = parser.parse_args()
    results_file = BenchmarkResults(tee=args.json)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        runs = study_runs(args.study, args.vehicles) if args.study else own_runs(args.curves, args.vehicles, Path(tmp))
        print(f"{'curve':<12} {'vehicle':<7} {'outcome':<13} {'gap [m]':>7} {'dominant':<16} {'fixes':<5} "
              f"{'sum/gap':>7} {'runs':>4} {'wall [s]':>8} {'run [s]':>7} {'ratio':>5}  shares [m]")
        for curve, vehicle, run_dir, outcome, gap in runs:
            if outcome == Outcome.GOAL_REACHED and gap <= args.threshold:
                continue
            if args.limit is not None and len(rows) >= args.limit:
                break
            x = explain(run_dir, args.workers)
            top = x.assumptions[0]
            total = sum(a.share_m for a in x.assumptions)
            ratio = total / gap if gap > 0 else float("nan")
            row = {"curve": curve, "vehicle": vehicle, "outcome": outcome, "gap_m": gap, "dominant": str(top.name),
                   "fixes_outcome": top.fixes_outcome, "sum_over_gap": ratio,
                   "adds_up": abs(ratio - 1.0) <= ADDS_UP, "runs": x.runs, "wall_s": x.wall_s,
                   "run_wall_s": x.run_wall_s, "explanation": x.as_json(), "sentence": x.sentence()}
            rows.append(row)
            shares = " ".join(f"{a.name}={a.share_m:.3f}" for a in x.assumptions)
            print(f"{curve:<12} {vehicle:<7} {outcome:<13} {gap:>7.3f} {top.name:<16} {str(top.fixes_outcome):<5} "
                  f"{ratio:>7.3f} {x.runs:>4} {x.wall_s:>8.1f} {x.run_wall_s:>7.1f} "
                  f"{x.wall_s / x.run_wall_s:>5.1f}  {shares}", flush=True)
    if rows:
        for vehicle in args.vehicles:
            mine = [r for r in rows if r["vehicle"] == vehicle]
            if mine:
                counts = Counter(r["dominant"] for r in mine)
                print(f"{vehicle}: dominant " + ", ".join(f"{k} {n}" for k, n in counts.most_common()) +
                      f" ({len(mine)} runs explained)")
        ratios = [r["wall_s"] / r["run_wall_s"] for r in rows]
        print(f"explanation wall time / run wall time: median {statistics.median(ratios):.1f}, largest "
              f"{max(ratios):.1f} (on {args.workers} workers)")
        off = [f"{r['curve']} {r['vehicle']} ({r['sum_over_gap']:.3f})" for r in rows if not r["adds_up"]]
        print("shares not adding up to the study's gap within 5 %: " + (", ".join(off) or "none"))
    if args.json:
        results_file.write(args.json, {"arguments": {k: str(v) for k, v in vars(args).items()}, "rows": rows})


if __name__ == "__main__":
    main()
