"""Where a study's time goes: the budget per phase of every run, and of the planning cycle.

Part one reads a finished experiment's store (e.g. `bench/paper_study.py --out DIR`): per fidelity
(low: the ideal world; high: the physical ones) the seconds all runs spent planning, in physics,
tyres, control, the rest of the backend's step, monitoring, the loop's own bookkeeping, scoring,
validity, writing the driven scenario, and the per-run overhead outside the loop (the scenario
loaded, agents and planners built, metrics, the run directory written): a job's time in its worker
less all of these. Given the study's wall time (``--wall``), the workers' time no run used (the
experiment's set-up, dispatch, the store) follows.

Part two (``--sample N``) runs N of the study's jobs again in this process, spread over its
scenarios and fidelities, with the Frenet planner's cycle broken into its phases (projection,
sampling, evaluation, collision, conversion; "other" is traffic prediction, goal checks, the
leeway at the road's edge and the hand-over) and the per-run overhead broken into loading the
scenario, building the planner and writing the run; it scales those shares to the store's totals.

    MUJOCO_GL=egl .venv/bin/python bench/paper_study.py --out DIR --workers 2
    MUJOCO_GL=egl .venv/bin/python bench/study_budget.py DIR --wall 300 --sample 24 --json FILE
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from collections import defaultdict
from pathlib import Path

from simgap.experiment.store import ResultsStore
from simgap.files import BenchmarkResults

LOOP = ("planning", "physics", "tyres", "control", "backend other", "monitoring", "loop other")
AFTER = ("scoring", "validation", "io")


def store_budget(root: Path) -> dict[str, dict[str, float]]:
    """Seconds per phase summed over the store's runs, per fidelity and for all ('runs' counts)."""
    _, rows = ResultsStore(root).query(
        "SELECT CASE WHEN backend = 'ideal' THEN 'low' ELSE 'high' END, count(*), sum(job_time_s), "
        "sum(wall_time_s), sum(time_planning_s), sum(coalesce(time_physics_s, 0)), "
        "sum(coalesce(time_tyres_s, 0)), sum(coalesce(time_control_s, 0)), sum(time_execution_s), "
        "sum(time_monitoring_s), sum(coalesce(time_scoring_s, 0)), sum(coalesce(time_validation_s, 0)), "
        "sum(coalesce(time_io_s, 0)) FROM runs WHERE status = 'ok' GROUP BY 1 ORDER BY 1 DESC")
    budget = {}
    for fid, n, job, wall, plan, phys, tyres, ctrl, execution, monitor, score, valid, io in rows:
        b = {"runs": n, "job": job, "planning": plan, "physics": phys, "tyres": tyres, "control": ctrl,
             "backend other": execution - phys - tyres - ctrl, "monitoring": monitor,
             "loop other": wall - plan - execution - monitor, "scoring": score, "validation": valid, "io": io}
        b["per-run overhead"] = job - wall - score - valid - io
        budget[fid] = b
    total = defaultdict(float)
    for b in budget.values():
        for k, v in b.items():
            total[k] += v
    budget["all"] = dict(total)
    return budget


def print_budget(budget: dict[str, dict[str, float]], wall: float | None, workers: int) -> None:
    phases = (*LOOP, *AFTER, "per-run overhead")
    fids = list(budget)
    print(f"{'phase':<18}" + "".join(f"{f + ' [s]':>12}{'share':>7}" for f in fids) + f"{'per run [s]':>13}")
    for p in (*phases, "job"):
        cells = "".join(f"{budget[f][p]:>12.1f}{100 * budget[f][p] / budget[f]['job']:>6.1f}%" for f in fids)
        print(f"{p:<18}{cells}{budget['all'][p] / budget['all']['runs']:>13.3f}")
    print("runs: " + ", ".join(f"{f} {budget[f]['runs']:.0f}" for f in fids))
    if wall:
        idle = workers * wall - budget["all"]["job"]
        print(f"study wall {wall:.1f} s x {workers} workers = {workers * wall:.1f} worker-s; the runs used "
              f"{budget['all']['job']:.1f}; set-up, dispatch, store and idle ends: {idle:.1f} "
              f"({100 * idle / (workers * wall):.1f} %)")


def sample_budget(root: Path, n: int) -> dict[str, float]:
    """Planning phases and per-run overhead of ``n`` of the study's jobs, run here again."""
    import simgap.experiment.single_run as single_run
    import simgap.planning.frenet as frenet
    from simgap.cosim import Run
    from simgap.experiment.job import JobContext
    from simgap.experiment.runner import plan as plan_jobs
    from simgap.experiment.spec import load_spec
    from simgap.experiment.worker import execute_job

    meta = json.loads((root / "experiment.json").read_text())
    experiment = load_spec(meta["spec_file"])
    jobs, scenarios = plan_jobs(experiment, root)
    chosen = jobs[:: max(1, len(jobs) // n)][:n]
    spent: dict[str, float] = defaultdict(float)

    def timed(name, fn):
        def wrapper(*args, **kwargs):
            start = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                spent[name] += time.perf_counter() - start
        return wrapper

    plan, init = frenet.FrenetPlanner.plan, frenet.FrenetPlanner.__init__

    def planning(self, *args, **kwargs):
        start = time.perf_counter()
        result = plan(self, *args, **kwargs)
        spent["planning"] += time.perf_counter() - start
        for phase, s in self.last_cycle.timings.items():
            spent[f"planning: {phase}"] += s
        spent["cycles"] += 1
        return result

    originals = [(frenet.FrenetPlanner, "plan", plan), (frenet.FrenetPlanner, "__init__", init),
                 (single_run, "load_scenario", single_run.load_scenario), (Run, "save", Run.save)]
    frenet.FrenetPlanner.plan = planning
    frenet.FrenetPlanner.__init__ = timed("planner built", init)
    single_run.load_scenario = timed("scenario loaded", single_run.load_scenario)
    Run.save = timed("run written", Run.save)
    try:
        with tempfile.TemporaryDirectory() as scratch:
            context = JobContext(Path(scratch), scenarios, experiment.planner_vehicle, validate=True)
            for job in chosen:
                start = time.perf_counter()
                row = execute_job(job, context)
                spent["job"] += time.perf_counter() - start
                spent["loop"] += row.wall_time_s
                for k in AFTER:
                    spent[k] += row.timings.get(k, 0.0)
    finally:
        for owner, name, fn in originals:
            setattr(owner, name, fn)
    spent["runs"] = len(chosen)
    return dict(spent)


def print_sample(spent: dict[str, float], budget: dict[str, dict[str, float]]) -> dict[str, float]:
    """The sample's shares, scaled to the store's planning total and per-run overhead."""
    total_planning = budget["all"]["planning"]
    phases = [k for k in spent if k.startswith("planning: ")]
    other = spent["planning"] - sum(spent[k] for k in phases)
    cycles = spent["cycles"]
    print(f"\nplanning cycle by phase ({spent['runs']:.0f} runs here, {cycles:.0f} cycles; scaled to the "
          f"study's {total_planning:.1f} s of planning)")
    print(f"{'phase':<26}{'per cycle [ms]':>15}{'share':>8}{'study [s]':>11}")
    scaled = {}
    for k, s in [*((k, spent[k]) for k in phases), ("planning: other", other)]:
        share = s / spent["planning"]
        scaled[k] = share * total_planning
        print(f"{k:<26}{1e3 * s / cycles:>15.2f}{100 * share:>7.1f}%{scaled[k]:>11.1f}")
    overhead = spent["job"] - spent["loop"] - sum(spent[k] for k in AFTER)
    known = ("scenario loaded", "planner built", "run written")
    print(f"\nper-run overhead ({1e3 * overhead / spent['runs']:.0f} ms per run here; scaled to the study's "
          f"{budget['all']['per-run overhead']:.1f} s)")
    for k in (*known, "rest"):
        s = spent[k] if k != "rest" else overhead - sum(spent[x] for x in known)
        share = s / overhead if overhead > 0 else 0.0
        scaled[k] = share * budget["all"]["per-run overhead"]
        print(f"{k:<26}{1e3 * s / spent['runs']:>12.0f} ms{100 * share:>7.1f}%{scaled[k]:>11.1f}")
    return scaled


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("study", type=Path, help="a finished experiment's directory")
    parser.add_argument("--wall", type=float, default=None, help="the study's wall time [s] (as it printed)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--sample", type=int, default=0, metavar="N", help="run N of its jobs again, instrumented")
    parser.add_argument("--json", type=Path, metavar="FILE",
                        help="also write what is printed, with commit, date, machine and load, to this results file")
    args = parser.parse_args()
    results_file = BenchmarkResults(tee=args.json)
    budget = store_budget(args.study)
    print(f"where the time of the {budget['all']['runs']:.0f} runs in {args.study} went (seconds of worker time)\n")
    print_budget(budget, args.wall, args.workers)
    figures = {"budget": budget}
    if args.sample:
        spent = sample_budget(args.study, args.sample)
        figures |= {"sample": spent, "scaled": print_sample(spent, budget)}
    if args.json:
        results_file.write(args.json, {"arguments": vars(args), **figures})


if __name__ == "__main__":
    main()
