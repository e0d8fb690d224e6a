"""One job as a worker executes it: its run directory, the run (`simgap.experiment.single_run`),
and the store row its record becomes (`RunRow.of`)."""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

from simgap.experiment.job import Job, JobContext
from simgap.experiment.replay import reproduce_command
from simgap.experiment.run_row import RunRow
from simgap.experiment.single_run import RunRequest, execute


def run_dir_of(root: Path, job: Job) -> Path:
    return Path(root) / "runs" / job.id.folder


def execute_job(job: Job, context: JobContext) -> RunRow:
    """Run ``job`` into its run directory under ``context.root`` and return its store row."""
    started = time.perf_counter()
    run_dir = run_dir_of(context.root, job)
    scenario = job.scenario_path or (context.scenarios or {})[job.scenario]
    request = RunRequest(scenario=Path(scenario), backend=job.backend, vehicles=job.vehicle,
                         planner_vehicle=context.planner_vehicle, backend_settings=job.backend_settings,
                         planner=job.planner, cosim=job.cosim, seed=job.seed, validate=context.validate,
                         criticality=context.criticality, evaluation=context.evaluation)
    record = execute(request, run_dir)
    row = RunRow.of(job, record, str(run_dir.relative_to(context.root)), time.perf_counter() - started)
    return replace(row, reproduce=reproduce_command(run_dir))
