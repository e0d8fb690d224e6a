"""Recorded traffic that no one here wrote: per scenario and world the outcome, its reason and the
wall time; goal rates per world and per kind (highway, urban, merge, roundabout, t_junction).

The corpus is a folder of public CommonRoad files with recorded traffic (highD, exiD, inD, SinD,
NGSIM, INTERACTION, the CommonRoad "T" scenarios); `bench/recorded/recorded_corpus.yaml` names each file's
source, licence and kind. The files are not shipped (most licences forbid it) and nothing is
downloaded: gather them once into a folder from clones of their repositories
(`bench/recorded/gather_recorded.py`, which checks each file's sha256) and pass it with ``--files``. Files
the manifest does not list run as kind ``other``. `bench/recorded/heldout_corpus.yaml` (``--manifest``) is a
second corpus, kept apart to tell how far what was tuned on the first carries.

An agent whose footprint at t = 0 already overlaps a recorded road user, or overhangs the road
(beyond the loop's off-road tolerance), starts in a collision: it is excluded from the rates and
listed. A crash of any kind is reported as outcome ``error`` with its message (the target is
none).

    MUJOCO_GL=egl .venv/bin/python bench/recorded/real_recorded.py --files DIR --worlds ideal mujoco --workers 2
    .venv/bin/python bench/recorded/real_recorded.py --files DIR --worlds ideal --only ZAM_Tjunction-1_23_T-1
    .venv/bin/python bench/recorded/real_recorded.py --files DIR --kind highway --json results.json
    .venv/bin/python bench/recorded/real_recorded.py --manifest bench/recorded/heldout_corpus.yaml --files HELDOUT --workers 2
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections import Counter, defaultdict
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass
from pathlib import Path

import yaml

from simgap.files import BenchmarkResults

MANIFEST = Path(__file__).with_name("recorded_corpus.yaml")
KINDS = ("highway", "urban", "merge", "roundabout", "t_junction", "other")


@dataclass
class AgentResult:
    scenario: str
    kind: str
    world: str
    agent: int | None
    outcome: str
    reason: str
    wall_s: float
    excluded: str = ""       # why the agent is not counted (starts in a collision or off the road)
    human: str = ""          # how the recorded human driver it replaces did ("" when the file has none)


def manifest_kinds(manifest: Path = MANIFEST) -> dict[str, str]:
    """File stem -> kind, from the manifest (empty when there is none)."""
    if not manifest.exists():
        return {}
    entries = yaml.safe_load(manifest.read_text()).get("files", [])
    return {Path(e["file"]).stem: e.get("kind", "other") for e in entries}


def start_conflicts(xml: Path) -> dict[int, str]:
    """Per agent id: why it starts in a collision (its footprint at t = 0 overlaps a recorded road
    user, or leaves the road beyond the loop's tolerance); agents that start clear are absent."""
    from simgap.cosim import CosimSettings
    from simgap.cosim.agents import agents_from_problems
    from simgap.cosim.traffic import ReplayedTraffic
    from simgap.scenario import load_scenario
    from simgap.scenario.obstacles import without_recorded_egos
    from simgap.scenario.road_frame import DrivableArea, footprint
    from simgap.vehicles import load_vehicle

    scenario, problems = load_scenario(xml)
    scenario, _ = without_recorded_egos(scenario, problems)     # as a run leaves them out
    dt = float(scenario.dt)
    agents = agents_from_problems(problems, dt, load_vehicle("sedan"))
    road = DrivableArea(scenario.lanelet_network, CosimSettings().offroad_tolerance)
    conflicts = {}
    for agent in agents:
        shape = footprint(agent.initial_state, agent.vehicle.length, agent.vehicle.width)
        poses = ReplayedTraffic(scenario).poses(agent.initial_state.t)
        hits = [oid for oid, (st, length, width) in poses.items()
                if shape.distance(footprint(st, length, width)) <= 0.0]
        others = [b for b in agents if b.id != agent.id and
                  shape.distance(footprint(b.initial_state, b.vehicle.length, b.vehicle.width)) <= 0.0]
        if hits or others:
            conflicts[agent.id] = f"overlaps road user {(hits + [b.id for b in others])[0]} at t = 0"
        elif (excursion := road.excursion(shape)) > 0.0:
            conflicts[agent.id] = f"footprint {excursion:.2f} m beyond the road at t = 0"
    return conflicts


def human_outcomes(xml: Path) -> dict[int, str]:
    """Per agent whose own recorded vehicle is in the file (the human driver it replaces): when that
    recording reaches the goal, or why it does not - how feasible the goal is for a human."""
    from simgap.scenario import load_scenario
    from simgap.scenario.goal import Goal
    from simgap.scenario.obstacles import recorded_egos, recorded_obstacles

    scenario, problems = load_scenario(xml)
    outcomes = {}
    motions = {o.id: o.motion for o in recorded_obstacles(scenario)}
    for pid, oid in recorded_egos(scenario, problems).items():
        goal = Goal.of(problems.planning_problem_dict[pid].goal, float(scenario.dt))
        states = list(motions[oid])
        reached = next((st for st in states if goal.is_reached(st)), None)
        outcomes[pid] = (f"goal at {reached.t:.1f} s" if reached is not None
                         else f"misses: {goal.miss_reason(states)}")
    return outcomes


def run_one(task: tuple[Path, str, str, str, str, Path | None, str | None]) -> list[AgentResult]:
    """Every agent's outcome of one scenario in one world (never raises)."""
    xml, world, kind, traffic, planner, planner_config, latency = task
    from simgap.cosim import CosimSettings
    from simgap.errors import InputError
    from simgap.experiment.single_run import RunRequest, execute, parse_planners

    clock = time.perf_counter()
    try:
        excluded = start_conflicts(xml)
        humans = human_outcomes(xml)
        record = execute(RunRequest(scenario=xml, backend=world, cosim=CosimSettings(traffic=traffic, **({"latency": latency} if latency else {})),
                                    planner=parse_planners(planner, planner_config)))
    except InputError as exc:
        return [AgentResult(xml.stem, kind, world, None, "refused", str(exc), time.perf_counter() - clock)]
    except Exception as exc:  # noqa: BLE001 - the benchmark reports every crash as an outcome
        return [AgentResult(xml.stem, kind, world, None, "error", f"{type(exc).__name__}: {exc}",
                            time.perf_counter() - clock)]
    wall = time.perf_counter() - clock
    results = []
    for agent in record.history.agents:
        events = [e for e in record.history.events if e.agent_id == agent.id and e.kind == agent.outcome]
        reason = events[-1].detail if events else ""
        if agent.outcome == "collision" and events:
            reason = f"with {events[-1].other_id} at t = {events[-1].t:.1f} s: {reason}"
        results.append(AgentResult(xml.stem, kind, world, agent.id, str(agent.outcome), reason, wall,
                                   excluded.get(agent.id, ""), humans.get(agent.id, "")))
    return results


def rates(results: list[AgentResult], world: str) -> tuple[dict[str, tuple[int, int]], int, float]:
    """Per kind (and 'all'): (goals, counted agents); errors; mean wall time per scenario. ``world``
    'human': the recorded human drivers the agents replace, where the files have them."""
    mine = [r for r in results if r.world == world] if world != "human" else \
        [r for r in {(r.scenario, r.agent): r for r in results if r.human}.values()]
    table: dict[str, list[int]] = defaultdict(lambda: [0, 0])
    for r in mine:
        if r.excluded or r.outcome == "refused":
            continue
        reached = r.human.startswith("goal") if world == "human" else r.outcome == "goal_reached"
        for key in (r.kind, "all"):
            table[key][0] += reached
            table[key][1] += 1
    walls = {r.scenario: r.wall_s for r in mine}
    errors = sum(r.outcome == "error" for r in mine)
    return {k: (v[0], v[1]) for k, v in table.items()}, errors, sum(walls.values()) / max(len(walls), 1)


def diff(before: Path, after: Path, worlds: list[str]) -> int:
    """Agent by agent, the outcomes of two results files: counts per world and every difference
    (its reason in each); how many outcomes differ."""
    def outcomes(path: Path) -> dict[tuple, dict]:
        data = json.loads(path.read_text())
        rows = data["rows"] if isinstance(data, dict) else data
        return {(r["scenario"], r["world"], r["agent"]): r for r in rows}
    old, new = outcomes(before), outcomes(after)
    worlds = [w for w in worlds if any(k[1] == w for k in old) and any(k[1] == w for k in new)]
    changed = 0
    for world in worlds:
        keys = sorted(k for k in old.keys() & new.keys() if k[1] == world)
        differ = [k for k in keys if old[k]["outcome"] != new[k]["outcome"]]
        changed += len(differ)
        print(f"{world}: {len(keys)} agents in both, {len(keys) - len(differ)} with the same outcome, "
              f"{len(differ)} different; only before {sum(k[1] == world for k in old.keys() - new.keys())}, "
              f"only after {sum(k[1] == world for k in new.keys() - old.keys())}")
        for k in differ:
            print(f"  {k[0]} agent {k[2]}: {old[k]['outcome']} ({old[k]['reason'][:90]}) -> "
                  f"{new[k]['outcome']} ({new[k]['reason'][:90]})")
    return changed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--files", type=Path, default=os.environ.get("SIMGAP_RECORDED"),
                        help="folder of recorded CommonRoad files (searched recursively; default $SIMGAP_RECORDED)")
    parser.add_argument("--worlds", nargs="+", default=["ideal", "mujoco"])
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--traffic", default="replay", choices=["replay", "idm"])
    parser.add_argument("--kind", nargs="+", default=None, choices=KINDS, help="only these kinds")
    parser.add_argument("--only", nargs="+", default=None, metavar="NAME", help="only these files (names without .xml)")
    parser.add_argument("--planner", default="frenet", help="the planner of every agent (as simgap run --planner)")
    parser.add_argument("--planner-config", type=Path, default=None, help="its settings (YAML)")
    parser.add_argument("--json", type=Path, default=None, help="also write every result to this JSON file")
    parser.add_argument("--latency", default=None, metavar="SECONDS",
                        help="the plans' latency in the physical worlds (default: measured, the planner's own "
                             "compute time, which makes a run on a loaded machine differ; a fixed one never does)")
    parser.add_argument("--manifest", type=Path, default=MANIFEST,
                        help=f"the corpus's manifest, for each file's kind (default {MANIFEST.name})")
    parser.add_argument("--diff", nargs=2, type=Path, metavar=("BEFORE", "AFTER"),
                        help="run nothing: compare two results files (--json) agent by agent and list every "
                             "outcome that differs (with --json FILE, what it printed goes there)")
    args = parser.parse_args()
    if args.diff:
        results_file = BenchmarkResults(tee=args.json)
        changed = diff(*args.diff, args.worlds)
        if args.json:
            results_file.write(args.json, {"before": str(args.diff[0]), "after": str(args.diff[1]),
                                           "outcomes_differ": changed})
        sys.exit(1 if changed else 0)
    results_file = BenchmarkResults()
    if args.files is None or not Path(args.files).is_dir():
        sys.exit(f"--files: a folder of recorded CommonRoad files is needed (got {args.files}); "
                 f"{args.manifest.name} names each file's source")
    kinds = manifest_kinds(args.manifest)
    files = sorted(Path(args.files).rglob("*.xml"), key=lambda p: p.stem)
    files = [p for p in files if (args.only is None or p.stem in args.only)
             and (args.kind is None or kinds.get(p.stem, "other") in args.kind)]
    missing = sorted(set(args.only or ()) - {p.stem for p in files})
    if missing:
        sys.exit(f"--only: no file named {', '.join(missing)} in {args.files} (names without .xml)")
    print(f"{len(files)} recorded scenarios in {args.files} ({dict(Counter(kinds.get(p.stem, 'other') for p in files))}), "
          f"worlds {', '.join(args.worlds)}, traffic {args.traffic}, latency {args.latency or 'measured'}, "
          f"planner {args.planner}"
          f"{' (' + str(args.planner_config) + ')' if args.planner_config else ''}, {args.workers} worker(s)\n")
    print(f"{'scenario':40s} {'kind':10s} {'world':7s} {'agent':>6s} {'outcome':16s} {'time [s]':>8s}  reason")
    tasks = [(xml, world, kinds.get(xml.stem, "other"), args.traffic, args.planner, args.planner_config, args.latency)
             for world in args.worlds for xml in files]
    results: list[AgentResult] = []
    clock = time.perf_counter()
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        for batch in pool.map(run_one, tasks):
            for r in batch:
                results.append(r)
                outcome = f"({r.outcome})" if r.excluded else r.outcome
                reason = r.excluded + ("; " if r.excluded else "") + r.reason
                if r.outcome != "goal_reached" and r.human:
                    reason += f" [human: {r.human}]"
                print(f"{r.scenario:40s} {r.kind:10s} {r.world:7s} {r.agent if r.agent is not None else '-':>6} "
                      f"{outcome:16s} {r.wall_s:8.1f}  {reason[:150]}", flush=True)
    print(f"\n{len(tasks)} runs in {time.perf_counter() - clock:.0f} s\n")
    excluded = sorted({(r.scenario, r.agent, r.excluded) for r in results if r.excluded})
    if excluded:
        print(f"excluded (start in a collision or off the road), {len(excluded)} agents:")
        for scenario, agent, why in excluded:
            print(f"  {scenario} agent {agent}: {why}")
        print()
    header = "world    " + "".join(f"{k:>16s}" for k in (*KINDS, "all")) + "   errors  wall/scenario"
    print(header)
    for world in [*args.worlds, "human"]:
        table, errors, wall = rates(results, world)
        cells = []
        for k in (*KINDS, "all"):
            goals, counted = table.get(k, (0, 0))
            cells.append(f"{goals}/{counted} {100 * goals / counted:3.0f}%" if counted else "-")
        tail = f"   {errors:6d}  {wall:8.1f} s" if world != "human" else "   (the recorded drivers, where a file has them)"
        print(f"{world:8s} " + "".join(f"{c:>16s}" for c in cells) + tail)
    if args.json is not None:
        results_file.write(args.json, [asdict(r) for r in results])
        print(f"\nresults written to {args.json}")


if __name__ == "__main__":
    main()
