"""Where the flat-world plan fails on 3D roads: the Frenet planner (simgap's default, replanning
every step) on the 3D roads' logical scenarios, in the ideal world (flat: the planner's assumption),
the dynamic single-track world and MuJoCo (sedan, pure pursuit), each on the 3D road and on its
flat twin — the same road with its relief removed — so the table separates what the third
dimension costs from what physics alone costs.

Every figure comes from simgap's own experiment runner: per family one experiment on the 3D
scenarios (ideal, dynamic, MuJoCo) and one on the flat twins (dynamic, MuJoCo; the ideal world
is flat already), specs written into ``OUT/specs`` and run with ``--workers`` processes, without
the solution check (`--no-validate`). The flat twin of a curve family is the `curve` logical
scenario at the same radius, angle and initial speed (the same lanelets: the ideal runs of the
3D roads and of their twins have the same fingerprints, which the script checks); the mountain
road's is `mountain-road` at grade 0. Grids are subsampled (``FAMILIES``) to run in about 15
minutes on 2 cores; `curve-3d` (the paper's curve grid x grade x bank) runs whole.

Per family and world: goals reached, max |d| (largest lateral offset from the lane's centre),
peak grip use (2D: the record's accelerations over mu g) and on the relief
(`peak_grip_use_3d`, `simgap.evaluate.surface_grip`: the normal load on the surface, gravity's
share along it; the ideal world's is what the flat plan asks of the real road), the closed-loop
score (CLS) and its drop against the ideal run of the same road. Then curve-3d by grade x bank.

Usage: python bench/roads/road_3d_study.py [--out studies/road3d] [--workers 2] [--families curve-3d ...]
       [--json-out bench/results/road_3d_study.json]
Re-running resumes the experiments in ``--out``. Prints the tables; no pass/fail.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import pyarrow.parquet as pq
import yaml

from simgap.experiment.runner import run_experiment
from simgap.files import BenchmarkResults

RESULTS = Path(__file__).resolve().parents[1] / "results" / "road_3d_study.json"
WORLDS = [("ideal", "ideal"), ("dynamic", "dynamic"), ("mujoco", "mujoco")]
RELIEF = ("grade", "grade_change", "vertical_radius", "vertical_curve_shift", "bank", "bank_transition")

# family -> (3D parameters narrowed to, flat twin's logical, flat twin's parameters)
FAMILIES: dict[str, tuple[dict, str, dict]] = {
    "curve-3d": ({}, "curve", {"radius": [10, 20, 30, 50], "angle": [90], "initial_speed": [0]}),
    "crest-curve": ({"radius": [20, 50], "vertical_radius": [75, 200]},
                    "curve", {"radius": [20, 50], "angle": [90], "initial_speed": [0]}),
    "sag-curve": ({"radius": [20, 50], "vertical_radius": [75, 200]},
                  "curve", {"radius": [20, 50], "angle": [90], "initial_speed": [0]}),
    "downhill-curve": ({"radius": [15, 30], "grade": [-15, -5]},
                       "curve", {"radius": [15, 30], "angle": [90], "initial_speed": [15]}),
    "banked-curve": ({"radius": [10, 20], "bank": [-10, -5, 0, 5, 10]},
                     "curve", {"radius": [10, 20], "angle": [90], "initial_speed": [10]}),
    "mountain-road": ({"hairpin_radius": [10], "grade": [-10, 8]},
                      "mountain-road", {"hairpin_radius": [10], "grade": [0]}),
}
ROAD_KEYS = ("radius", "angle", "initial_speed", "hairpin_radius")     # what makes two roads the same in 2D


def spec(name: str, logical: str, parameters: dict, backends: list[str]) -> dict:
    fidelities = [{"backend": "ideal"} if b == "ideal" else
                  {"backend": b, "vehicles": ["sedan"], "controllers": ["pure_pursuit"]} for b in backends]
    return {"name": name, "logical": logical, "sampler": {"kind": "grid"},
            "parameters": {k: {"values": v} for k, v in parameters.items()},
            "fidelities": fidelities, "planners": ["frenet"], "planner_vehicle": "sedan",
            "cosim": {"replan_every": 1}, "repeats": 1, "seed": 0}


def run(out: Path, name: str, body: dict, workers: int) -> list[dict]:
    specs = out / "specs"
    specs.mkdir(parents=True, exist_ok=True)
    path = specs / f"{name}.yaml"
    path.write_text(yaml.safe_dump(body, sort_keys=False))
    result = run_experiment(path, out / name, workers, validate=False)
    print(f"[{name}: {result.total} runs, {result.ran} ran now ({result.failed} failed), "
          f"{result.wall_time_s:.0f} s]", flush=True)
    return pq.read_table(out / name / "store" / "results.parquet").to_pylist()


def road_of(row: dict) -> tuple:
    return tuple(row.get(f"param_{k}") for k in ROAD_KEYS)


def finite(values):
    return [v for v in values if v is not None and not (isinstance(v, float) and math.isnan(v))]


def summary(rows: list[dict], ideal_score: dict) -> dict:
    ok = [r for r in rows if r["status"] == "ok"]
    d = finite(r["max_lateral_offset_m"] for r in ok)
    drops = finite(ideal_score.get(road_of(r), math.nan) - r["score"] for r in ok if r["score"] is not None)
    outcomes: dict[str, int] = {}
    for r in ok:
        outcomes[r["outcome"]] = outcomes.get(r["outcome"], 0) + 1
    return {"runs": len(rows), "failed_runs": len(rows) - len(ok),
            "goals": sum(int(r["goals_reached"] or 0) for r in ok), "outcomes": outcomes,
            "max_d_median_m": _median(d), "max_d_max_m": max(d, default=math.nan),
            "grip_2d_max": max(finite(r["peak_grip_use"] for r in ok), default=math.nan),
            "grip_3d_max": max(finite(r["peak_grip_use_3d"] for r in ok), default=math.nan),
            "score_mean": _mean(finite(r["score"] for r in ok)),
            "score_drop_mean": _mean(drops), "score_drop_max": max(drops, default=math.nan)}


def _mean(xs):
    return sum(xs) / len(xs) if xs else math.nan


def _median(xs):
    xs = sorted(xs)
    return (xs[(len(xs) - 1) // 2] + xs[len(xs) // 2]) / 2 if xs else math.nan


def compact(r: dict) -> dict:
    keep = ("backend", "status", "outcome", "goals_reached", "max_lateral_offset_m", "max_lane_excursion_m",
            "peak_grip_use", "peak_grip_use_3d", "score", "fingerprint", "wall_time_s")
    return {**{k[6:]: v for k, v in r.items() if k.startswith("param_") and v is not None},
            **{k: r.get(k) for k in keep}}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("studies/road3d"))
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--families", nargs="+", choices=list(FAMILIES), default=list(FAMILIES))
    parser.add_argument("--json-out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    results_file = BenchmarkResults()
    families = {}
    for family in args.families:
        narrowed, flat_logical, flat_parameters = FAMILIES[family]
        relief_rows = run(args.out, family, spec(family, family, {k: v for k, v in narrowed.items()},
                                                 ["ideal", "dynamic", "mujoco"]), args.workers)
        flat_rows = run(args.out, f"{family}-flat", spec(f"{family}-flat", flat_logical, flat_parameters,
                                                         ["ideal", "dynamic", "mujoco"]), args.workers)
        ideal_score = {road_of(r): r["score"] for r in flat_rows if r["backend"] == "ideal" and r["status"] == "ok"}
        flat_prints = {road_of(r): r["fingerprint"] for r in flat_rows if r["backend"] == "ideal"}
        same_plan = all(flat_prints.get(road_of(r)) == r["fingerprint"]
                        for r in relief_rows if r["backend"] == "ideal" and r["status"] == "ok")
        worlds = {}
        for backend, label in WORLDS:
            worlds[f"{label} 3D"] = summary([r for r in relief_rows if r["backend"] == backend], ideal_score)
            if backend != "ideal":
                worlds[f"{label} flat"] = summary([r for r in flat_rows if r["backend"] == backend], ideal_score)
        families[family] = {"scenarios": len({road_of(r) + tuple(r.get(f"param_{k}") for k in RELIEF)
                                              for r in relief_rows}),
                            "parameters": narrowed, "flat_twin": {"logical": flat_logical, **flat_parameters},
                            "ideal_3d_equals_flat_twin": same_plan, "worlds": worlds,
                            "runs": [compact(r) for r in relief_rows],
                            "flat_runs": [compact(r) for r in flat_rows]}
    print_tables(families)
    results = {"workers": args.workers, "planner": "frenet (defaults), replan every step", "vehicle": "sedan",
               "controller": "pure_pursuit", "families": families}
    written = json.loads(results_file.write(args.json_out, results).read_text())
    print(f"\n[wrote {args.json_out}; {written['wall_time_s']:.0f} s wall; commit {written['commit']}]")


def print_tables(families: dict) -> None:
    header = (f"{'family':<15} {'world':<13} {'goals':>7} {'max|d| med/max [m]':>19} {'grip 2D':>7} "
              f"{'grip 3D':>7} {'CLS':>5} {'drop mean/max':>13}  outcomes")
    print("\n" + header + "\n" + "-" * len(header))
    for family, f in families.items():
        for world, s in f["worlds"].items():
            n = s["runs"] - s["failed_runs"]
            others = ", ".join(f"{k} {v}" for k, v in sorted(s["outcomes"].items()) if k != "goal_reached")
            print(f"{family:<15} {world:<13} {s['goals']:>3}/{n:<3} {s['max_d_median_m']:>9.2f}/{s['max_d_max_m']:<9.2f}"
                  f" {s['grip_2d_max']:>7.2f} {s['grip_3d_max']:>7.2f} {s['score_mean']:>5.2f} "
                  f"{s['score_drop_mean']:>6.2f}/{s['score_drop_max']:<6.2f}  {others}")
    grid = families.get("curve-3d")
    if not grid:
        return
    print("\ncurve-3d, MuJoCo sedan on the 3D road against its flat twin (per grade x bank, over radius 10/20/30/50 m):")
    flat = {r["radius"]: r for r in grid["flat_runs"] if r["backend"] == "mujoco"}
    ideal = {r["radius"]: r for r in grid["flat_runs"] if r["backend"] == "ideal"}
    print(f"{'grade %':>7} {'bank deg':>8} {'goals':>5} {'max|d| per radius [m]':>26} {'flat twin':>22} "
          f"{'grip 3D max':>11} {'CLS drop max':>12}")
    cells: dict[tuple, list] = {}
    for r in grid["runs"]:
        if r["backend"] == "mujoco" and r["status"] == "ok":
            cells.setdefault((r["grade"], r["bank"]), []).append(r)
    for (grade, bank), rs in sorted(cells.items()):
        rs.sort(key=lambda r: r["radius"])
        ds = "/".join(f"{r['max_lateral_offset_m']:.2f}" for r in rs)
        fs = "/".join(f"{flat[r['radius']]['max_lateral_offset_m']:.2f}" for r in rs if r["radius"] in flat)
        drop = max(ideal[r["radius"]]["score"] - r["score"] for r in rs if r["radius"] in ideal)
        print(f"{grade:>7g} {bank:>8g} {sum(int(r['goals_reached'] or 0) for r in rs):>3}/{len(rs):<1} {ds:>26} "
              f"{fs:>22} {max(r['peak_grip_use_3d'] for r in rs):>11.2f} {drop:>12.3f}")


if __name__ == "__main__":
    main()
