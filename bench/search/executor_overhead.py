"""What an executor adds to each run: the local process pool against Ray, on the same spec.

For every run, the time from handing it to a free worker slot until its result is back on the
driver, minus the time the run took inside the worker (``job_time_s``), is what the executor
adds: sending the job, starting or waking a worker, returning the row (and, for Ray, shipping the
scenario out and the run directory back, which the driver writes). The first run of each slot
also pays for starting its worker process; the steady state is the median of the others. The
connection (for Ray: connecting and probing the nodes) is timed apart.

Usage: python bench/search/executor_overhead.py [--spec demo] [--workers 2] [--address HOST:PORT | ray://HOST:PORT]
       (without --address: a local Ray cluster of --workers CPUs, started by this script)
Prints a table in seconds; no pass/fail. On a shared machine, compare lines of one invocation.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from simgap.experiment.executors import make_executor
from simgap.experiment.job import JobContext
from simgap.experiment.runner import plan
from simgap.experiment.spec import load_spec
from simgap.files import BenchmarkResults


def measure(executor: str, spec: str, workers: int, address: str | None) -> dict[str, float]:
    with tempfile.TemporaryDirectory(prefix="simgap-bench-") as tmp:
        root = Path(tmp)
        experiment = load_spec(spec)
        spec_model = experiment.spec
        jobs, scenarios = plan(experiment, root)
        context = JobContext(root, scenarios, experiment.planner_vehicle)
        t0 = time.perf_counter()
        runner = make_executor(executor, workers, spec_model.run_timeout_s, address)
        connect_s = time.perf_counter() - t0
        queue, handed, added = list(jobs), {}, []

        def next_job():
            if not queue:
                return None
            job = queue.pop(0)
            handed[job.key] = time.perf_counter()
            return job

        def on_result(job, row) -> None:
            added.append(time.perf_counter() - handed[job.key] - float(row.job_time_s or 0.0))

        t0 = time.perf_counter()
        runner.run(next_job, context, on_result)
        wall = time.perf_counter() - t0
    first, rest = added[:workers], added[workers:]
    return {"runs": len(added), "connect_s": connect_s, "wall_s": wall, "first_s": statistics.mean(first),
            "steady_s": statistics.median(rest) if rest else float("nan")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spec", default="demo")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--address", default=None)
    parser.add_argument("--json", type=Path, metavar="FILE",
                        help="also write what is printed, with commit, date, machine and load, to this results file")
    args = parser.parse_args()
    results_file = BenchmarkResults(tee=args.json)
    rows = [("local pool", measure("local", args.spec, args.workers, None)),
            (f"ray {args.address or '(local cluster)'}", measure("ray", args.spec, args.workers, args.address))]
    print(f"{'executor':34} {'runs':>4} {'connect':>8} {'wall':>7} {'added, first runs':>18} {'added, median':>14}")
    for name, r in rows:
        print(f"{name:34} {r['runs']:4d} {r['connect_s']:8.2f} {r['wall_s']:7.1f} {r['first_s']:18.2f} "
              f"{r['steady_s']:14.3f}")
    if args.json:
        results_file.write(args.json, {"arguments": vars(args),
                                       "executors": dict(rows)})


if __name__ == "__main__":
    main()
