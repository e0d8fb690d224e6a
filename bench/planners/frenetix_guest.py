"""The paper's planner as a guest: the Frenetix motion planner (TUM-AVS, PyPI 2024.1.1, in its own
Python 3.10 behind the planner protocol: examples/frenetix_motion_planner) against simgap's own
`frenet` planner on the paper's curves, in the ideal world and in MuJoCo with the sedan.

Every run is `simgap run SCENARIO --backend B --planner P --replan-every 3` (the paper replanned
every third step), the guest as ``exec:.venv/bin/python serve.py`` with a planning deadline of
``--deadline`` seconds (Frenetix takes 0.2-0.6 s per call on average here, up to 5 s on the
loaded shared machine); every pair of worlds is
`simgap compare`. Per planner and world: goals reached, the closed-loop score (the run record's
agents' score), the largest distance from the route's lane centre (its metric
max_lateral_offset_m), planning cycles without a plan and the mean wall time per planning
call; per planner: max |d| per curve (|d_mujoco - d_ideal| at equal arc length along the lane
centre, `simgap compare`'s lateral displacement, the paper's metric), its median and maximum over
the curves, and the grid of it. Writes bench/results/frenetix_guest.json.

Usage: python bench/planners/frenetix_guest.py [--radii 10,20,30,50] [--angles 45,90,135] [--workers 2]
       [--planners frenet,frenetix] [--latency 0.1|measured] [--out runs/frenetix-guest] [--fresh]

MuJoCo's real car takes each plan after a latency: by default here a fixed 0.1 s (one step, what
simgap's frenet gets), so that the two planners differ by their plans, not by the speed of the
machine; ``--latency measured`` is simgap's default (the planner's compute time rounded up to
steps: Frenetix's plans then reach the car 0.5-1 s late on average).
Planners: frenet (simgap's), frenetix (the guest, planning from the observed state) and
frenetix-planned (the guest planning from its previous plan's state, as Frenetix's own loop and
MultiDrive did). Runs already in --out are reused unless --fresh. Without the guest's virtual
environment this prints how to make it and exits 0.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import statistics
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from simgap.files import BenchmarkResults

ROOT = Path(__file__).resolve().parents[2]
GUEST = ROOT / "examples" / "frenetix_motion_planner"
GUEST_PYTHON = GUEST / ".venv" / "bin" / "python"
SIMGAP = Path(sys.executable).with_name("simgap")
RESULTS = ROOT / "bench" / "results" / "frenetix_guest.json"
BACKENDS = ("ideal", "mujoco")
REPLAN_EVERY = 3


def planner_args(planner: str, deadline: float) -> list[str]:
    """`simgap run` options of a planner of this study."""
    if planner == "frenet":
        return ["--planner", "frenet"]
    command = f"exec:{shlex.quote(str(GUEST_PYTHON))} {shlex.quote(str(GUEST / 'serve.py'))}"
    if planner == "frenetix-planned":
        command += " start=planned"
    elif planner != "frenetix":
        raise SystemExit(f"unknown planner {planner!r}: frenet, frenetix or frenetix-planned")
    return ["--planner", command, "--planner-deadline", str(deadline)]


def scenarios(radii: list[float], angles: list[float], folder: Path) -> dict[tuple, Path]:
    """The curve scenarios (simgap's `curve`, the paper's road), written to ``folder``."""
    from simgap.scenario import load_logical, write_scenario
    spec = load_logical("curve")
    out = {}
    for r in radii:
        for a in angles:
            (params,) = spec.grid(spec.pinned({"radius": str(r), "angle": str(a)}))
            out[(r, a)] = write_scenario(spec.build(params), folder, preview=False)
    return out


def world(backend: str, latency: str) -> str:
    """The folder of a world's runs: the backend, and MuJoCo's plan latency unless measured."""
    return backend if backend == "ideal" or latency == "measured" else f"{backend}-latency{float(latency):g}"


def run(scenario: Path, planner: str, backend: str, out: Path, deadline: float, latency: str, fresh: bool) -> dict:
    """One `simgap run` (reused from ``out`` unless ``fresh``): its record as `simgap run --json` prints
    it, with its metrics and "reused" added."""
    from simgap.record import read_run

    record = out / "run.json"
    reused = record.exists() and not fresh
    if not reused:
        command = [str(SIMGAP), "run", str(scenario), "--backend", backend, "--out", str(out), "--overwrite",
                   "--replan-every", str(REPLAN_EVERY), *planner_args(planner, deadline)]
        if backend != "ideal" and latency != "measured":
            command += ["--knob", f"latency={float(latency):g}"]
        done = subprocess.run(command, capture_output=True, text=True, env={"MUJOCO_GL": "egl", **os.environ})
        if done.returncode != 0 or not record.exists():
            return {"failure": f"simgap run exited {done.returncode}: {done.stderr.strip()[-600:]}", "agents": []}
    kept = read_run(out)
    return {**kept.summary(), "metrics": dict(kept.evaluation.metrics), "reused": reused}


def compare(ideal: Path, mujoco: Path) -> float | None:
    """max |d| of agent 1 between two runs (`simgap compare`)."""
    done = subprocess.run([str(SIMGAP), "compare", str(ideal), str(mujoco), "--json"], capture_output=True, text=True)
    if done.returncode != 0:
        return None
    agents = json.loads(done.stdout)["agents"]
    return agents[0]["lateral_displacement"]["max"] if agents else None


def summarise(rows: list[dict], planners: list[str]) -> dict:
    summary = {}
    for planner in planners:
        mine = [r for r in rows if r["planner"] == planner]
        entry = {}
        for backend in BACKENDS:
            agents = [r["agent"] for r in mine if r["backend"] == backend and r["agent"]]
            calls = sum(a["planning_calls"] for a in agents)
            entry[backend] = {
                "runs": sum(r["backend"] == backend for r in mine),
                "goals": sum(a["outcome"] == "goal_reached" for a in agents),
                "score_mean": statistics.fmean(a["score"] for a in agents) if agents else None,
                "score_min": min((a["score"] for a in agents), default=None),
                "max_offset_median_m": statistics.median(r["max_lateral_offset_m"] for r in mine
                                                         if r["backend"] == backend) if agents else None,
                "failed_cycles": sum(a["planner_failures"] for a in agents),
                "ms_per_call_mean": 1000 * sum(a["planning_mean_s"] * a["planning_calls"] for a in agents) / calls
                if calls else None,
                "ms_per_call_max": 1000 * max((a["planning_max_s"] for a in agents), default=0.0),
                "plan_latency_mean_s": statistics.fmean(a["plan_latency_mean_s"] or 0.0 for a in agents)
                if agents else None,
                "outcomes": sorted({a["outcome"] for a in agents}),
            }
        d = [r["max_d_m"] for r in mine if r["backend"] == "mujoco" and r["max_d_m"] is not None]
        entry["max_d_median_m"] = statistics.median(d) if d else None
        entry["max_d_max_m"] = max(d) if d else None
        summary[planner] = entry
    return summary


def fmt(value, spec: str) -> str:
    return "-" if value is None else format(value, spec)


def print_tables(rows: list[dict], summary: dict, radii, angles) -> None:
    print(f"\n{'planner':<17} {'world':<7} {'goals':>6} {'score mean':>10} {'min':>6} {'offset med':>10} "
          f"{'failed':>6} {'ms/call':>8} {'max ms':>7} {'latency':>7}  outcomes")
    for planner, entry in summary.items():
        for backend in BACKENDS:
            e = entry[backend]
            goals = f"{e['goals']}/{e['runs']}"
            print(f"{planner:<17} {backend:<7} {goals:>6} {fmt(e['score_mean'], '.3f'):>10} "
                  f"{fmt(e['score_min'], '.3f'):>6} {fmt(e['max_offset_median_m'], '.3f'):>10} {e['failed_cycles']:>6} "
                  f"{fmt(e['ms_per_call_mean'], '.1f'):>8} {fmt(e['ms_per_call_max'], '.0f'):>7} "
                  f"{fmt(e['plan_latency_mean_s'], '.2f'):>7}  "
                  f"{','.join(e['outcomes'])}")
    print("\nmax |d| [m] between the ideal world and MuJoCo (simgap compare) over the curves")
    print(f"{'planner':<17} {'median':>7} {'max':>7}")
    for planner, entry in summary.items():
        print(f"{planner:<17} {fmt(entry['max_d_median_m'], '.3f'):>7} {fmt(entry['max_d_max_m'], '.3f'):>7}")
    for planner in summary:
        print(f"\n{planner}: max |d| [m], radius down, angle across")
        print(f"{'r [m]':>6} " + " ".join(f"{a:>7g}°" for a in angles))
        for r in radii:
            cells = [next((x["max_d_m"] for x in rows if x["planner"] == planner and x["backend"] == "mujoco"
                           and x["radius"] == r and x["angle"] == a), None) for a in angles]
            print(f"{r:>6g} " + " ".join(f"{fmt(c, '.3f'):>8}" for c in cells))
    for r in rows:
        if r.get("failure"):
            print(f"failed: {r['planner']} {r['backend']} r{r['radius']:g} a{r['angle']:g}: {r['failure']}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--radii", default="10,20,30,50")
    parser.add_argument("--angles", default="45,90,135")
    parser.add_argument("--planners", default="frenet,frenetix")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--deadline", type=float, default=5.0, help="the guest's planning deadline [s]")
    parser.add_argument("--latency", default="0.1", help="MuJoCo: the plan latency [s] (one step: what frenet's "
                        "plans have on the real car), or 'measured' (simgap's default: the planner's compute time "
                        "rounded up to steps, which makes a slow planner's car a late one)")
    parser.add_argument("--out", type=Path, default=ROOT / "runs" / "frenetix-guest")
    parser.add_argument("--fresh", action="store_true", help="run again what --out already holds")
    args = parser.parse_args()
    results_file = BenchmarkResults()
    planners = args.planners.split(",")
    radii = [float(x) for x in args.radii.split(",")]
    angles = [float(x) for x in args.angles.split(",")]
    if any(p != "frenet" for p in planners) and not (GUEST / ".venv" / ".installed").exists():
        print(f"The Frenetix guest's virtual environment is missing ({GUEST / '.venv'}); make it with\n"
              f"    make -C {GUEST.relative_to(ROOT)}\n(Python 3.10 and PyPI, about a minute), then run this again.")
        return
    for p in planners:
        planner_args(p, args.deadline)
    start = time.perf_counter()
    files = scenarios(radii, angles, args.out / "scenarios")
    jobs = [(key, p, b) for key in files for p in planners for b in BACKENDS]

    def job(item):
        (r, a), p, b = item
        record = run(files[(r, a)], p, b, args.out / p / f"r{r:g}_a{a:g}" / world(b, args.latency), args.deadline,
                     args.latency, args.fresh)
        agent = record["agents"][0] if record.get("agents") else None
        print(f"  {p} {b} r{r:g} a{a:g}: {agent['outcome'] if agent else record.get('failure')}",
              file=sys.stderr, flush=True)
        return {"planner": p, "backend": b, "radius": r, "angle": a, "agent": agent,
                "failure": record.get("failure"), "wall_time_s": record.get("wall_time_s"),
                "reused": record.get("reused", False),
                "plan_latency_mean_s": agent["plan_latency_mean_s"] if agent else None,
                "max_lateral_offset_m": (record.get("metrics") or {}).get("max_lateral_offset_m"), "max_d_m": None}

    with ThreadPoolExecutor(args.workers) as pool:
        rows = list(pool.map(job, jobs))
    for row in rows:
        if row["backend"] == "mujoco" and row["agent"]:
            base = args.out / row["planner"] / f"r{row['radius']:g}_a{row['angle']:g}"
            row["max_d_m"] = compare(base / "ideal", base / world("mujoco", args.latency))
    summary = summarise(rows, planners)
    print_tables(rows, summary, radii, angles)
    wall = time.perf_counter() - start
    ran = sum(not r["reused"] for r in rows)
    print(f"\n{len(rows)} runs ({ran} now, {len(rows) - ran} reused from --out) in {wall:.0f} s with {args.workers} workers (replan every {REPLAN_EVERY} steps; "
          f"sedan; MuJoCo's plan latency {args.latency}{' s' * (args.latency != 'measured')}; the guest's deadline "
          f"{args.deadline:g} s; runs in {args.out})")
    requirements = (GUEST / "requirements.txt").read_text().splitlines()
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    results = json.loads(RESULTS.read_text()) if RESULTS.exists() else {}
    results = results if "variants" in results else {"variants": {}}     # one entry per MuJoCo latency setting
    earlier = results["variants"].get(f"latency={args.latency}", {})      # other planners' rows are kept
    rows = [r for r in earlier.get("runs", []) if r["planner"] not in planners] + rows
    summary = {**{k: v for k, v in earlier.get("summary", {}).items() if k not in planners}, **summary}
    results["variants"][f"latency={args.latency}"] = {
        "command": " ".join([Path(sys.argv[0]).name, *sys.argv[1:]]), "wall_s": round(wall, 1),
        "workers": args.workers, "replan_every": REPLAN_EVERY, "guest_deadline_s": args.deadline,
        "mujoco_plan_latency": args.latency, "radii": radii, "angles": angles, "cpus": os.cpu_count(),
        "load_average": os.getloadavg(),
        "guest": [line for line in requirements if line.startswith(("frenetix", "commonroad-io"))],
        "summary": summary, "runs": rows}
    results_file.write(RESULTS, results)
    print(f"written {RESULTS.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
