"""Planners in a process of their own: what a planning call costs, and what a hostile planner costs a batch.

Part 1, overhead per planning call. The Frenet planner drives the paper's curves (r = 10, 30,
50 m, 90 degrees) in the ideal world; the states it observed are then replayed, in order, to the
same planner three ways, and every call is timed where the loop times it (around ``plan``):

    in-process   the planner class in simgap's own process (the default)
    isolated     the same class in a child process of simgap's interpreter (--isolate)
    constant     a planner that does next to nothing (a constant-speed line), in-process and
                 isolated: the difference is the protocol's own cost per call (encode, ZeroMQ
                 round trip over ipc://, decode), with no planning to hide it

Median and p95 per call, and the isolated minus in-process difference of the medians.

Part 2, a 12-run experiment with hostile planners (`simgap experiment run`, ideal world): three
curves x four planners in their own process: one that keeps its lane, one that hangs, one that
segfaults, one that returns garbage (a dict). Every run must be recorded, none lost or repeated,
and the batch must finish; prints the store's rows (status, outcome, the reason) and the wall time.

    MUJOCO_GL=egl .venv/bin/python bench/planners/planner_process.py [--json bench/results/planner_process.json]
        [--part overhead|hostile|all] [--workers 2]

On 2 cores, run it with the machine otherwise idle (or pinned: taskset -c 1).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np

from simgap.cosim import simulate
from simgap.cosim.agents import agents_from_problems
from simgap.experiment.store import ResultsStore
from simgap.files import BenchmarkResults
from simgap.planning.frenet import FrenetPlanner
from simgap.planning.protocol import PlannerSetup, World
from simgap.planning.registry import load_planner
from simgap.planning.remote import IsolatedPlannerClass
from simgap.record import read_run
from simgap.scenario import build_scenario, load_scenario
from simgap.scenario.files import write_scenario
from simgap.sim.registry import make_backend
from simgap.trajectory import Trajectory
from simgap.vehicles import load_vehicle

REPO = Path(__file__).resolve().parents[2]
SERVERS = REPO / "tests" / "protocol" / "servers.py"
RADII = (10.0, 30.0, 50.0)

CONSTANT = '''
import numpy as np
from simgap.trajectory import Trajectory

class Constant:
    """A straight line at the observed speed: next to no work per call."""

    def __init__(self, setup):
        self.dt = setup.dt

    def plan(self, observed, t, world):
        k = np.arange(31) * self.dt
        c, s = np.cos(observed.yaw), np.sin(observed.yaw)
        z = np.zeros(31)
        return Trajectory(self.dt, t=t + k, x=observed.x + observed.v * k * c, y=observed.y + observed.v * k * s,
                          yaw=z + observed.yaw, v=z + observed.v, a=z, yaw_rate=z, steer=z)
'''


def observed_states(xml: Path) -> tuple[list, PlannerSetup]:
    """The states the Frenet planner observed on its ideal run of ``xml`` (every step), and its setup."""
    scenario, problems = load_scenario(xml)
    sedan = load_vehicle("sedan")
    problem = next(iter(problems.planning_problem_dict.values()))
    setup = PlannerSetup(problem.planning_problem_id, sedan, scenario.lanelet_network, problem, float(scenario.dt))
    agents = agents_from_problems(problems, scenario.dt, sedan)
    history = simulate(scenario, problems, make_backend("ideal"), agents, {setup.agent_id: FrenetPlanner(setup)})
    return list(history.driven[setup.agent_id])[:-1], setup


def call_times(planner, states, setup: PlannerSetup) -> np.ndarray:
    world = World(setup.lanelet_network, setup.planning_problem.goal, setup.dt)
    times = []
    for state in states:
        clock = time.perf_counter()
        plan = planner.plan(state, state.t, world)
        times.append(time.perf_counter() - clock)
        assert plan is None or isinstance(plan, Trajectory)
    if callable(getattr(planner, "close", None)):
        planner.close()
    return np.array(times)


def overhead(folder: Path) -> dict:
    constant_file = folder / "constant.py"
    constant_file.write_text(CONSTANT)
    classes = {"frenet": load_planner("frenet"), "constant": load_planner(f"{constant_file}:Constant")}
    rows = []
    for radius in RADII:
        xml = write_scenario(build_scenario("curve", {"radius": radius, "angle": 90.0}), folder, preview=False)
        states, setup = observed_states(xml)
        for name, planner_class in classes.items():
            for mode, factory in (("in-process", planner_class), ("isolated", IsolatedPlannerClass(planner_class))):
                settings = factory.settings({})
                times = call_times(factory.build(setup, settings), states, setup) * 1000.0
                rows.append({"radius_m": radius, "planner": name, "mode": mode, "calls": len(times),
                             "median_ms": float(np.median(times)), "p95_ms": float(np.percentile(times, 95))})
                print(f"r = {radius:4.0f} m  {name:9s} {mode:11s} {len(times):4d} calls  median "
                      f"{rows[-1]['median_ms']:7.3f} ms  p95 {rows[-1]['p95_ms']:7.3f} ms", flush=True)
    summary = {}
    for name in classes:
        diffs = [next(r["median_ms"] for r in rows if r["radius_m"] == radius and r["planner"] == name
                      and r["mode"] == "isolated") -
                 next(r["median_ms"] for r in rows if r["radius_m"] == radius and r["planner"] == name
                      and r["mode"] == "in-process") for radius in RADII]
        summary[name] = {"isolated_minus_in_process_median_ms": diffs}
        print(f"{name}: isolated - in-process, median per call: " + ", ".join(f"{d:+.3f} ms" for d in diffs))
    return {"calls": rows, "overhead": summary}


def hostile(folder: Path, workers: int = 2) -> dict:
    spec = folder / "hostile.yaml"
    spec.write_text(textwrap.dedent(f"""\
        name: hostile-planners
        description: three curves x four planners in their own process, one of them well-behaved
        logical: curve
        parameters:
          radius: {{values: [10, 30, 50]}}
          angle: {{values: [90]}}
        sampler: {{kind: grid}}
        fidelities:
          - backend: ideal
        planners:
          - {{planner: "exec:{sys.executable} {SERVERS} keep_lane", label: keep-lane}}
          - {{planner: "exec:{sys.executable} {SERVERS} hang", label: hangs, process: {{deadline_s: 0.2}}}}
          - {{planner: "exec:{sys.executable} {SERVERS} segfault", label: segfaults}}
          - {{planner: "exec:{sys.executable} {SERVERS} dict", label: garbage}}
        """))
    out = folder / "experiment"
    clock = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "simgap", "experiment", "run", str(spec), "--out", str(out),
                           "--workers", str(workers), "--no-report"], capture_output=True, text=True)
    wall = time.perf_counter() - clock
    rows = sorted(({k: r.get(k) for k in ("key", "planner", "status", "outcome", "failure")}
                   for r in ResultsStore(out).rows()), key=lambda r: (r["planner"], r["key"]))
    run_files = sorted((out / "runs").rglob("run.json"))
    run_dirs = [p.parent.relative_to(out / "runs") for p in run_files]
    reasons = {}
    for path, folder in zip(run_files, run_dirs):       # why each agent ended: its last event's detail
        history = read_run(path.parent).history
        reasons[(folder.parts[0], folder.name.partition("@")[2])] = next(
            (e.detail for e in reversed(history.events) if e.kind == history.agents[0].outcome), "")
    print(f"experiment exit code {done.returncode}, wall time {wall:.1f} s, {len(rows)} rows, "
          f"{len(set(r['key'] for r in rows))} distinct keys, {len(run_dirs)} run directories")
    for r in rows:
        r["reason"] = reasons.get((r["key"].split("/")[0], r["planner"]), "")
        print(f"  {r['planner']:10s} {r['status']:8s} {r['outcome'] or '':16s} {(r['failure'] or r['reason'])[:90]}")
    if done.returncode != 0:
        print(done.stderr[-2000:])
    return {"exit_code": done.returncode, "wall_time_s": wall, "rows": rows, "run_directories": len(run_dirs)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", type=Path)
    parser.add_argument("--part", choices=("overhead", "hostile", "all"), default="all")
    parser.add_argument("--workers", type=int, default=2, help="the hostile experiment's workers")
    args = parser.parse_args()
    results_file = BenchmarkResults()
    result = {}
    with tempfile.TemporaryDirectory() as tmp:
        if args.part in ("overhead", "all"):
            result["overhead"] = overhead(Path(tmp))
        if args.part in ("hostile", "all"):
            result["hostile"] = hostile(Path(tmp), args.workers)
    if args.json:
        results_file.write(args.json, result)


if __name__ == "__main__":
    main()
