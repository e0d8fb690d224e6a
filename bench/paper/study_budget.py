"""Where a study's time goes: the budget per phase of every run, and of the planning cycle.

Part one reads a finished experiment's store (e.g. `bench/paper/paper_study.py --out DIR`): per fidelity
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

    MUJOCO_GL=egl .venv/bin/python bench/paper/paper_study.py --out DIR --workers 2
    MUJOCO_GL=egl .venv/bin/python bench/paper/study_budget.py DIR --wall 300 --sample 24 --json FILE
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from collections import defaultdict
from pathlib import Path

from simgap.files import BenchmarkResults
from simgap.report.time_budget import TimeBudget, budget_lines, store_budget

AFTER = ("scoring", "validation", "io")


def sample_budget(root: Path, n: int) -> dict[str, float]:
    """Planning phases and per-run overhead of ``n`` of the study's jobs, run here again."""
    import simgap.experiment.run_scene as run_scene
    import simgap.experiment.single_run as single_run
    import simgap.planning.frenet as frenet
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
                 (run_scene, "load_scenario", run_scene.load_scenario),
                 (single_run, "write_run", single_run.write_run)]
    frenet.FrenetPlanner.plan = planning
    frenet.FrenetPlanner.__init__ = timed("planner built", init)
    run_scene.load_scenario = timed("scenario loaded", run_scene.load_scenario)
    single_run.write_run = timed("run written", single_run.write_run)
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


def print_sample(spent: dict[str, float], budget: dict[str, TimeBudget]) -> dict[str, float]:
    """The sample's shares, scaled to the store's planning total and per-run overhead."""
    total_planning = budget["all"].phases["planning"]
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
          f"{budget['all'].phases['per-run overhead']:.1f} s)")
    for k in (*known, "rest"):
        s = spent[k] if k != "rest" else overhead - sum(spent[x] for x in known)
        share = s / overhead if overhead > 0 else 0.0
        scaled[k] = share * budget["all"].phases["per-run overhead"]
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
    print(f"where the time of the {budget['all'].runs} runs in {args.study} went (seconds of worker time)\n")
    print("\n".join(budget_lines(budget, args.wall, args.workers)))
    figures = {"budget": {f: {"runs": b.runs, "job_s": b.job_s, **b.phases} for f, b in budget.items()}}
    if args.sample:
        spent = sample_budget(args.study, args.sample)
        figures |= {"sample": spent, "scaled": print_sample(spent, budget)}
    if args.json:
        results_file.write(args.json, {"arguments": vars(args), **figures})


if __name__ == "__main__":
    main()
